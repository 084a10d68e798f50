#include "calibd/core/solve/box_cost.hpp"

#include <Eigen/Geometry>
#include <cmath>

#include "solve/box_hinge.hpp"

namespace calibd {

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
  return detail::HingeResidual(p_board, half_extent_);  // Eq. 1
}

bool BoardBoxCost::Evaluate(double const* const* parameters, double* residuals,
                            double** jacobians) const {
  const double* x = parameters[0];
  const Eigen::Quaterniond q(x[6], x[3], x[4], x[5]);
  const Eigen::Matrix3d R = q.normalized().toRotationMatrix();
  const Eigen::Vector3d t(x[0], x[1], x[2]);
  double* J = jacobians != nullptr ? jacobians[0] : nullptr;

  for (int i = 0; i < num_used_; ++i) {
    Eigen::Vector3d r;
    Eigen::Matrix<double, 3, 6> dr;
    detail::FixedBoardPointResidual(R, t, R_board_camera_, t_board_camera_,
                                    points_[i * stride_].cast<double>(), half_extent_, huber_, &r,
                                    J != nullptr ? &dr : nullptr);
    Eigen::Map<Eigen::Vector3d>(residuals + 3 * i) = r;
    if (J == nullptr) continue;
    Eigen::Map<Eigen::Matrix<double, 3, 7, Eigen::RowMajor>> Ji(J + 21 * i);
    Ji.leftCols<6>() = dr;
    Ji.col(6).setZero();
  }
  return true;
}

}  // namespace calibd
