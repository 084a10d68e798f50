#pragma once
/// \file
/// Camera-LiDAR board correspondences: what the coarse grid search hands to the optimisation
/// (paper §III-D/E). Points live in one pool sized once from the config.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "calibd/core/geometry.hpp"

namespace calibd {

/// One board seen by both sensors in one frame pair.
struct BoardObservation {
  int frame = -1;                             ///< frame pair it came from
  int board_index = -1;                       ///< index into the configured boards
  Pose T_camera_board = Pose::Identity();     ///< from the camera detection (PnP)
  std::array<Eigen::Vector2d, 4> corners_px;  ///< detected tag corners (AprilTag order)
  int first_point = 0;  ///< this board's LiDAR points in ObservationSet::points
  int num_points = 0;
};

/// All correspondences of a session. `points` are LiDAR-frame board points (metres).
struct ObservationSet {
  std::vector<BoardObservation> observations;
  std::vector<Eigen::Vector3f> points;

  /// Appends an observation with its points; false (nothing added) when it would exceed the
  /// capacity reserved by the caller, so memory stays fixed.
  bool Add(const BoardObservation& obs, const Eigen::Vector3f* board_points, int count);
};

}  // namespace calibd
