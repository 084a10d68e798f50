#pragma once
/// \file
/// Per-board pose fit in the LiDAR frame (paper Eq. 2-3, after Huang & Grizzle 2020): T_lidar_board
/// minimising the box cost of one cluster's points, from an initial guess (T_camera_board and the
/// coarse extrinsic). The indirect method and the paper's Table I metric build on it.

#include <Eigen/Core>
#include <string>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

struct BoardFitResult {
  bool usable = false;
  std::string reason;
  Pose T_lidar_board = Pose::Identity();
  double residual_rms_m = 0.0;
  int iterations = 0;
};

/// Fits the board of half sizes (half_width, half_height), box half-thickness `alpha`, to `points`
/// (LiDAR frame). `huber_m` as in DirectOptimizerConfig. The solve stops after `max_iterations`
/// or when an iteration changes the cost by less than `function_tolerance` (relative) or the pose
/// by less than `parameter_tolerance` (relative); the defaults are Ceres'.
BoardFitResult FitBoardPose(const Eigen::Vector3f* points, int num_points, double half_width,
                            double half_height, double alpha, double huber_m,
                            const Pose& T_lidar_board_init, int max_iterations = 50,
                            double function_tolerance = 1e-6, double parameter_tolerance = 1e-8);

}  // namespace calibd
