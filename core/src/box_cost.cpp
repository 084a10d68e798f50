#include "calibd/core/box_cost.hpp"

#include <Eigen/Geometry>
#include <cmath>

namespace calibd {

namespace {

Eigen::Matrix3d Skew(const Eigen::Vector3d& v) {
  Eigen::Matrix3d S;
  S << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return S;
}

}  // namespace

BoardBoxCost::BoardBoxCost(const Eigen::Vector3f* points, int num_points, int stride,
                           const Pose& T_board_camera, double half_width, double half_height,
                           double alpha, double huber_m)
    : points_(points),
      num_used_(stride > 1 ? (num_points + stride - 1) / stride : num_points),
      stride_(stride > 1 ? stride : 1),
      R_board_camera_(T_board_camera.linear()),
      t_board_camera_(T_board_camera.translation()),
      half_extent_(half_width, half_height, alpha),
      huber_(huber_m) {
  set_num_residuals(3 * num_used_);
  mutable_parameter_block_sizes()->push_back(7);
}

Eigen::Vector3d BoardBoxCost::PointResidual(const Pose& T_camera_lidar, int i) const {
  const Eigen::Vector3d p_board =
      R_board_camera_ * (T_camera_lidar * points_[i * stride_].cast<double>()) + t_board_camera_;
  Eigen::Vector3d r;
  for (int k = 0; k < 3; ++k) {
    const double excess = std::abs(p_board[k]) - half_extent_[k];  // Eq. 1
    r[k] = excess > 0.0 ? std::copysign(excess, p_board[k]) : 0.0;
  }
  return r;
}

bool BoardBoxCost::Evaluate(double const* const* parameters, double* residuals,
                            double** jacobians) const {
  const double* x = parameters[0];
  const Eigen::Quaterniond q(x[6], x[3], x[4], x[5]);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector3d t(x[0], x[1], x[2]);
  double* J = jacobians != nullptr ? jacobians[0] : nullptr;

  for (int i = 0; i < num_used_; ++i) {
    const Eigen::Vector3d p_cam = R * points_[i * stride_].cast<double>() + t;
    const Eigen::Vector3d p_board = R_board_camera_ * p_cam + t_board_camera_;
    // Signed hinge r = sign(lambda) c(lambda, a) = lambda - sign(lambda) a outside the box, so
    // dr/dlambda is 1 where the hinge is active and 0 inside.
    Eigen::Vector3d r;
    Eigen::Vector3d active;
    for (int k = 0; k < 3; ++k) {
      const double excess = std::abs(p_board[k]) - half_extent_[k];  // Eq. 1
      active[k] = excess > 0.0 ? 1.0 : 0.0;
      r[k] = excess > 0.0 ? std::copysign(excess, p_board[k]) : 0.0;
    }
    // Huber on the point's residual norm n: the residual becomes g(n) r/n with g = sqrt(rho(n^2)),
    // so its squared norm is exactly rho; Jacobian [g' u u^T + (g/n)(I - u u^T)] dr/dx.
    const double n = r.norm();
    double scale_along = 1.0, scale_across = 1.0;
    if (huber_ > 0.0 && n > huber_) {
      const double g = std::sqrt(2.0 * huber_ * n - huber_ * huber_);
      scale_across = g / n;
      scale_along = huber_ / g;  // g'(n) = rho'(n^2) n / g with rho' = huber / n
    }
    const Eigen::Vector3d u = n > 0.0 ? Eigen::Vector3d(r / n) : Eigen::Vector3d::Zero();
    Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = scale_across * r;
    if (J == nullptr) continue;
    // dp_board/d[dt, dtheta] with the left perturbation R' = Exp(dtheta) R (PoseManifold).
    Eigen::Matrix<double, 3, 6> dp;
    dp.leftCols<3>() = R_board_camera_;
    dp.rightCols<3>() = -R_board_camera_ * Skew(R * points_[i * stride_].cast<double>());
    const Eigen::Matrix<double, 3, 6> dr = active.asDiagonal() * dp;
    const Eigen::Matrix3d robust = scale_along * u * u.transpose() +
                                   scale_across * (Eigen::Matrix3d::Identity() - u * u.transpose());
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> Ji(J + 21 * i);
    Ji.leftCols<6>() = robust * dr;
    Ji.col(6).setZero();
  }
  return true;
}

}  // namespace calibd
