#pragma once
// Private to the box costs: the per-point signed hinge of paper Eq. 1/3 with its per-point Huber
// loss, shared by BoardBoxCost (board pose fixed) and BoardBoxJointCost (board pose refined); the
// Huber loss also serves the board-pose refinement's corners.

#include <Eigen/Core>
#include <cmath>

namespace calibd::detail {

inline Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

/// Unrobust residual of a point in the board frame: per axis sign(lambda) c(lambda, a), c of
/// paper Eq. 1 (|lambda| - a outside the box, 0 inside).
inline Eigen::Vector3d HingeResidual(const Eigen::Vector3d& p_board,
                                     const Eigen::Vector3d& half_extent) {
  Eigen::Vector3d r;
  for (int k = 0; k < 3; ++k) {
    const double excess = std::abs(p_board[k]) - half_extent[k];
    r[k] = excess > 0.0 ? std::copysign(excess, p_board[k]) : 0.0;
  }
  return r;
}

/// Whether a residual of this squared norm lies beyond Huber's threshold `huber` (<= 0: no loss),
/// where the loss below changes it.
inline bool BeyondHuber(double squared_norm, double huber) {
  return huber > 0.0 && squared_norm > huber * huber;
}

/// Huber's rho itself: the squared norm of the robust residual of a residual of squared norm s.
inline double HuberRho(double s, double huber) {
  return BeyondHuber(s, huber) ? 2.0 * huber * std::sqrt(s) - huber * huber : s;
}

/// Huber's loss (Ceres' HuberLoss: rho(s) = s up to huber^2, 2 huber sqrt(s) - huber^2 beyond)
/// on a residual r of norm n, as a residual g(n) r / n with g = sqrt(rho(n^2)), so that its
/// squared norm is exactly rho: `across` = g / n scales r, and its Jacobian is
/// [along u u^T + across (I - u u^T)] dr with u = r / n and `along` = g'(n). Both 1 within
/// `huber` (<= 0: no loss).
inline void HuberScales(double n, double huber, double* along, double* across) {
  *along = *across = 1.0;
  if (!BeyondHuber(n * n, huber)) return;
  const double g = std::sqrt(2.0 * huber * n - huber * huber);
  *across = g / n;
  *along = huber / g;  // g'(n) = rho'(n^2) n / g with rho' = huber / n
}

/// The robust residual of a point and d(residual)/d(p_board). The signed hinge has slope 1 where
/// active and 0 inside the box; Huber on the residual norm (HuberScales) makes the Jacobian
/// [along u u^T + across (I - u u^T)] diag(active): diag(active) within Huber's threshold, where
/// most points are (inside the board's outline, off its plane by the range noise).
inline void RobustHinge(const Eigen::Vector3d& p_board, const Eigen::Vector3d& half_extent,
                        double huber, Eigen::Vector3d* residual, Eigen::Matrix3d* d_residual) {
  const Eigen::Vector3d r = HingeResidual(p_board, half_extent);
  const double n = r.norm();
  double scale_along = 1.0, scale_across = 1.0;
  HuberScales(n, huber, &scale_along, &scale_across);
  *residual = scale_across * r;
  if (d_residual == nullptr) return;
  Eigen::Vector3d active;
  for (int k = 0; k < 3; ++k) active[k] = r[k] != 0.0 ? 1.0 : 0.0;
  if (!BeyondHuber(n * n, huber)) {
    *d_residual = active.asDiagonal();
    return;
  }
  const Eigen::Vector3d u = r / n;
  *d_residual = (scale_along * u * u.transpose() +
                 scale_across * (Eigen::Matrix3d::Identity() - u * u.transpose())) *
                active.asDiagonal();
}

/// A LiDAR point's robust residual (RobustHinge) for the extrinsic T = (R, t) with the board pose
/// held (p_B = R_bc (R p + t) + t_bc) and, when `d_pose` is set, its derivative in the tangent
/// space [dt, dtheta] of the left perturbation R' = Exp(dtheta) R (PoseManifold):
/// dp_B = R_bc dt - R_bc [R p]x dtheta.
inline void FixedBoardPointResidual(const Eigen::Matrix3d& R, const Eigen::Vector3d& t,
                                    const Eigen::Matrix3d& R_bc, const Eigen::Vector3d& t_bc,
                                    const Eigen::Vector3d& p, const Eigen::Vector3d& half_extent,
                                    double huber, Eigen::Vector3d* residual,
                                    Eigen::Matrix<double, 3, 6>* d_pose) {
  const Eigen::Vector3d p_rotated = R * p;
  const Eigen::Vector3d p_board = R_bc * (p_rotated + t) + t_bc;
  Eigen::Matrix3d dr_dp;
  RobustHinge(p_board, half_extent, huber, residual, d_pose != nullptr ? &dr_dp : nullptr);
  if (d_pose == nullptr) return;
  const Eigen::Matrix3d dr_dt = dr_dp * R_bc;
  d_pose->leftCols<3>() = dr_dt;
  d_pose->rightCols<3>() = -dr_dt * Skew(p_rotated);
}

}  // namespace calibd::detail
