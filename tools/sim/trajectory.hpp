#pragma once
/// \file
/// The vehicle's path in the workshop (paper §IV-A: back and forth 6-30 m from the boards for 20 s,
/// 10 Hz). Vehicle frame V: x forward, y left, z up, origin on the ground; facing the boards
/// (+x_W).

#include <string>

#include "calibd/core/common/geometry.hpp"

namespace calibd::sim {

struct TrajectoryOptions {
  /// "drive" (back and forth between min and max distance), "static" (parked at static_distance),
  /// "close" (back and forth within 6-8.5 m) or "far" (within 25-30 m): paper Table II subsets;
  /// "stills": parked at static_distance while the boards move between frames (stills.hpp).
  std::string mode = "drive";
  double min_distance_m = 6.0;   ///< LiDAR-to-board-line distance at the near end
  double max_distance_m = 30.0;  ///< at the far end
  double static_distance_m = 10.0;
  double duration_s = 20.0;
  double rate_hz = 10.0;       ///< frame pairs per second
  double weave_m = 0.4;        ///< lateral weave amplitude while driving
  double yaw_weave_deg = 2.0;  ///< heading weave amplitude while driving

  bool IsValid(std::string* error) const;
  int num_frames() const;
};

/// T_world_vehicle at time t (s) from the session start, for a LiDAR mounted at `lidar_x_m` ahead
/// of the vehicle origin (distances are measured from the LiDAR to the board line x_W = 0).
Pose VehiclePoseAt(const TrajectoryOptions& o, double lidar_x_m, double t);

}  // namespace calibd::sim
