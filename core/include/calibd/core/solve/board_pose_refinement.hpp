#pragma once
/// \file
/// One board's pose refined with the extrinsic held: the direct optimiser's board-pose
/// refinement (DirectOptimizerConfig::refine_board_poses), board by board.

#include <array>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/solve/board_box_joint_cost.hpp"
#include "calibd/core/solve/corner_reprojection_cost.hpp"

namespace calibd {

/// What one board's refinement weighs: its LiDAR points' box cost through the held extrinsic, and
/// those of its tag corners the camera saw (the first `num_corners`), each under a Huber loss of
/// `corner_huber` on its residual norm.
struct BoardPoseTerms {
  const BoardBoxJointCost* box = nullptr;
  const double* T_camera_lidar = nullptr;  ///< 7 parameters (PoseToParameters), held
  std::array<const CornerReprojectionCost*, 4> corners{};
  int num_corners = 0;
  double corner_huber = 0.0;
};

/// Minimises the terms' cost over T_camera_board from `*T_camera_board` by Levenberg-Marquardt
/// (ceres::TinySolver) on a left perturbation [dt, dtheta] of the start, as a ceres::Problem of
/// the same blocks would on PoseManifold, without a Problem's set-up, which cost several times
/// the evaluations for these 6 unknowns and ~200 residuals (hundreds of boards a solve). At most
/// `max_iterations`; the cost's relative change below `function_tolerance` ends it. Updates the
/// pose and returns true unless the solve left it unusable (not finite, or the cost grew).
bool RefineBoardPose(const BoardPoseTerms& terms, int max_iterations, double function_tolerance,
                     Pose* T_camera_board);

}  // namespace calibd
