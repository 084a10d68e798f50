#include "calibd/core/solve/board_box_joint_cost.hpp"

#include <Eigen/Geometry>

#include "solve/box_hinge.hpp"

namespace calibd {

BoardBoxJointCost::BoardBoxJointCost(const Eigen::Vector3f* points, int num_points, int stride,
                                     double half_width, double half_height, double alpha,
                                     double huber_m)
    : points_(points),
      num_used_(stride > 1 ? (num_points + stride - 1) / stride : num_points),
      stride_(stride > 1 ? stride : 1),
      half_extent_(half_width, half_height, alpha),
      huber_(huber_m) {
  set_num_residuals(3 * num_used_);
  mutable_parameter_block_sizes()->push_back(7);  // T_camera_lidar
  mutable_parameter_block_sizes()->push_back(7);  // T_camera_board
}

bool BoardBoxJointCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const double* x = parameters[0];
  const double* b = parameters[1];
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(x[6], x[3], x[4], x[5]).normalized().toRotationMatrix();
  const Eigen::Vector3d t(x[0], x[1], x[2]);
  const Eigen::Matrix3d R_cb =
      Eigen::Quaterniond(b[6], b[3], b[4], b[5]).normalized().toRotationMatrix();
  const Eigen::Vector3d t_cb(b[0], b[1], b[2]);
  const Eigen::Matrix3d R_bc = R_cb.transpose();
  double* J_ext = jacobians != nullptr ? jacobians[0] : nullptr;
  double* J_board = jacobians != nullptr ? jacobians[1] : nullptr;

  for (int i = 0; i < num_used_; ++i) {
    const Eigen::Vector3d p_rotated = R * points_[i * stride_].cast<double>();
    const Eigen::Vector3d from_board = p_rotated + t - t_cb;  // camera frame, board origin
    const Eigen::Vector3d p_board = R_bc * from_board;
    Eigen::Vector3d r;
    Eigen::Matrix3d dr_dp;
    const bool want_jacobian = J_ext != nullptr || J_board != nullptr;
    detail::RobustHinge(p_board, half_extent_, huber_, &r, want_jacobian ? &dr_dp : nullptr);
    Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = r;
    if (!want_jacobian) continue;
    // Left perturbations (PoseManifold): T_camera_lidar: t' = t + dt, R' = Exp(dtheta) R gives
    // dp_B = R_bc dt - R_bc [R p]x dtheta; T_camera_board: t_cb' = t_cb + dt_b,
    // R_cb' = Exp(dtheta_b) R_cb gives dp_B = -R_bc dt_b + R_bc [p_C - t_cb]x dtheta_b.
    if (J_ext != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> Ji(J_ext + 21 * i);
      Ji.leftCols<3>() = dr_dp * R_bc;
      Ji.middleCols<3>(3) = -dr_dp * R_bc * detail::Skew(p_rotated);
      Ji.col(6).setZero();
    }
    if (J_board != nullptr) {
      Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> Ji(J_board + 21 * i);
      Ji.leftCols<3>() = -dr_dp * R_bc;
      Ji.middleCols<3>(3) = dr_dp * R_bc * detail::Skew(from_board);
      Ji.col(6).setZero();
    }
  }
  return true;
}

}  // namespace calibd
