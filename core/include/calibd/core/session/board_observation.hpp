#pragma once
/// \file
/// Camera-LiDAR board correspondences: what the coarse grid search hands to the optimisation
/// (paper §III-D/E). Points live in one pool sized once from the config.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "calibd/core/camera/board_outline.hpp"
#include "calibd/core/common/geometry.hpp"

namespace calibd {

/// One board seen by both sensors in one frame pair.
struct BoardObservation {
  int frame = -1;                             ///< frame pair it came from
  int board_index = -1;                       ///< index into the configured boards
  Pose T_camera_board = Pose::Identity();     ///< from the camera detection (PnP)
  std::array<Eigen::Vector2d, 4> corners_px;  ///< detected tag corners (AprilTag order)
  BoardOutline outline;  ///< the board's edges as the camera saw them (board_outline.hpp)
  int first_point = 0;   ///< this board's LiDAR points in ObservationSet::points
  int num_points = 0;
  /// The LiDAR cluster the points came from: its index in the SessionObservations::lidar the
  /// engine was given (-1 when the points did not come from a session's cluster).
  int lidar_cluster = -1;
  /// Apparent velocity of the board centre in the camera frame (m/s), when known
  /// (board_motion.hpp); CompensateBoardMotion moves the points by it.
  Eigen::Vector3d velocity = Eigen::Vector3d::Zero();
  bool has_velocity = false;
};

/// All correspondences of a session. `points` are LiDAR-frame board points (metres); `point_dt`
/// their firing time minus the camera's capture time (s).
struct ObservationSet {
  std::vector<BoardObservation> observations;
  std::vector<Eigen::Vector3f> points;
  std::vector<float> point_dt;
  /// True once CompensateBoardMotion moved the points to the camera's capture time.
  bool motion_compensated = false;
  /// The camera time offset (s) the compensated points were moved for (ShiftToCaptureTime).
  double time_offset_s = 0.0;

  /// Empties the set and reserves room once (fixed memory: Add never grows beyond it).
  void Reserve(int max_observations, int max_points);
  void Clear();

  /// Appends an observation with its points (`dt` may be null: all 0); false (nothing added)
  /// when it would exceed the reserved capacity.
  bool Add(const BoardObservation& obs, const Eigen::Vector3f* board_points, const float* dt,
           int count);

  /// Keeps the observations i with keep[i] != 0 (and their points), in order, in place; returns
  /// how many were removed. `keep` has one entry per observation.
  int KeepOnly(const std::vector<char>& keep);
  /// Keeps the points k with keep_point[k] != 0, in order, in place (every observation stays,
  /// with fewer points); returns how many were removed. `keep_point` has one entry per point.
  int KeepPoints(const std::vector<char>& keep_point);
};

}  // namespace calibd
