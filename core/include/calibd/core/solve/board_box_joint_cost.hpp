#pragma once
/// \file
/// The box cost of one board observation (paper Eq. 3 and 5) with the board's pose in the camera
/// frame as a second unknown: Ceres parameter blocks T_camera_lidar and T_camera_board (both
/// PoseManifold; either may be held constant). With CornerReprojectionCost on the same board
/// pose, the direct optimisation weighs the camera's and the LiDAR's evidence of every board
/// instead of taking the camera's PnP pose as exact (direct_optimizer.hpp). The residual per point
/// is that of BoardBoxCost (signed hinge, per-point Huber): p_B = T_camera_board^-1 *
/// T_camera_lidar * p.

#include <ceres/cost_function.h>

#include <Eigen/Core>

namespace calibd {

class BoardBoxJointCost final : public ceres::CostFunction {
 public:
  /// `points` (LiDAR frame, m) must outlive the cost. `stride` > 1 uses every stride-th point.
  BoardBoxJointCost(const Eigen::Vector3f* points, int num_points, int stride, double half_width,
                    double half_height, double alpha, double huber_m);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Eigen::Vector3f* points_;
  int num_used_, stride_;
  Eigen::Vector3d half_extent_;  ///< (width/2, height/2, alpha)
  double huber_;
};

}  // namespace calibd
