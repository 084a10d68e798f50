#pragma once
// Private to the box costs: the per-point signed hinge of paper Eq. 1/3 with its per-point Huber
// loss, shared by BoardBoxCost (board pose fixed) and BoardBoxJointCost (board pose refined).

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

/// The robust residual of a point and d(residual)/d(p_board). The signed hinge has slope 1 where
/// active and 0 inside the box. Huber on the residual norm n: the residual becomes g(n) r/n with
/// g = sqrt(rho(n^2)), so its squared norm is exactly rho; its Jacobian is
/// [g' u u^T + (g/n)(I - u u^T)] diag(active).
inline void RobustHinge(const Eigen::Vector3d& p_board, const Eigen::Vector3d& half_extent,
                        double huber, Eigen::Vector3d* residual, Eigen::Matrix3d* d_residual) {
  const Eigen::Vector3d r = HingeResidual(p_board, half_extent);
  const double n = r.norm();
  double scale_along = 1.0, scale_across = 1.0;
  if (huber > 0.0 && n > huber) {
    const double g = std::sqrt(2.0 * huber * n - huber * huber);
    scale_across = g / n;
    scale_along = huber / g;  // g'(n) = rho'(n^2) n / g with rho' = huber / n
  }
  *residual = scale_across * r;
  if (d_residual == nullptr) return;
  const Eigen::Vector3d u = n > 0.0 ? Eigen::Vector3d(r / n) : Eigen::Vector3d::Zero();
  Eigen::Vector3d active;
  for (int k = 0; k < 3; ++k) active[k] = r[k] != 0.0 ? 1.0 : 0.0;
  *d_residual = (scale_along * u * u.transpose() +
                 scale_across * (Eigen::Matrix3d::Identity() - u * u.transpose())) *
                active.asDiagonal();
}

}  // namespace calibd::detail
