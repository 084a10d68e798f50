#pragma once
/// \file
/// The indirect baseline (Huang & Grizzle 2020, paper §III-E, Eq. 1-3): fit each board's pose in
/// the LiDAR frame, map its tag corners into the LiDAR frame, then solve T_camera_lidar by PnP +
/// RANSAC over all (LiDAR corner, detected image corner) pairs. Kept for comparison with the
/// direct method.

#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/session/board_observation.hpp"

namespace calibd {

struct IndirectOptimizerConfig {
  double alpha_m = 0.0;
  double huber_m = 0.05;
  double ransac_threshold_px = 4.0;  ///< inlier reprojection error
  int ransac_iterations = 500;
};

struct IndirectResult {
  bool usable = false;
  std::string reason;
  Pose T_camera_lidar = Pose::Identity();
  int boards_fitted = 0;
  int inliers = 0;  ///< corners consistent with the solution
  int correspondences = 0;
  double reprojection_mean_px = 0.0;  ///< fitted LiDAR corners vs camera corners, inliers
};

/// `T_camera_lidar_init` (the grid search's result) seeds each board fit as T_lidar_camera *
/// T_camera_board.
IndirectResult OptimizeIndirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                                const CameraModel& camera, const Pose& T_camera_lidar_init,
                                const IndirectOptimizerConfig& config);

}  // namespace calibd
