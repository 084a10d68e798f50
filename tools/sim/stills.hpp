#pragma once
/// \file
/// Still-pose sessions, as most calibration rigs record them: the sensors stand still and, for
/// each pose, people place the board(s) somewhere else in front of them (on a tripod or held by
/// hand), turned as people turn them, among the room's furniture. Each pose is a scene of its own.

#include <cstdint>
#include <functional>
#include <string>

#include "calibd/core/lidar/lidar_model.hpp"
#include "workshop.hpp"

namespace calibd::sim {

struct StillPoseOptions {
  double min_distance_m = 1.5;  ///< LiDAR to board centre
  double max_distance_m = 8.0;
  double max_yaw_deg = 40.0;   ///< board turned about the vertical, either way
  double max_tilt_deg = 25.0;  ///< tipped forward or back
  double max_roll_deg = 15.0;  ///< turned in its own plane
  /// Clutter within 0.3-1 m of the boards: a person holding the board (else a tripod), a chair,
  /// a wall behind, a box on the floor behind and below, a bystander. False: tripods only.
  bool clutter = true;
  /// Frame pairs recorded per pose, one LiDAR sweep apart (a stream recorded while the board
  /// stood still); the poses stay 1 / trajectory.rate_hz apart.
  int frames_per_pose = 1;
  /// Fault: someone stands between the sensors and every board, 0.4-0.8 m in front of it,
  /// hiding about this share of its width from the LiDAR (a column 0.35 m wide, floor to 2 m,
  /// on a side drawn at random); 0: nobody.
  double occluded_share = 0.0;
  /// Fault: the boards are still being carried while a pose's frames are taken, at this speed
  /// (m/s) in a horizontal direction drawn per pose and board, from where the pose placed them at
  /// its first frame; each sensor sees them where they are at its own time (SessionSimulator).
  /// 0: the boards stand still.
  double board_speed_mps = 0.0;
};

/// True when a board at T_world_board is usable by the camera (the caller's camera model).
using BoardVisible = std::function<bool(const Pose& T_world_board, const BoardGeometry& g)>;

/// Builds the scene of still pose `pose`: a room (floor, walls, furniture along them) and the
/// workshop options' boards, each placed at random within the distances in front of the LiDAR at
/// T_world_lidar, inside the LiDAR's field of view and where `visible` accepts it, apart from
/// each other. Deterministic per (seed, pose). False with `error` when no placement was found.
bool BuildStillPose(const WorkshopOptions& workshop, const StillPoseOptions& options,
                    const LidarModel& lidar, const Pose& T_world_lidar, const BoardVisible& visible,
                    uint64_t seed, int pose, Workshop* out, std::string* error);

}  // namespace calibd::sim
