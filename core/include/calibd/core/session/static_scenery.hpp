#pragma once
/// \file
/// Static scenery among a session's LiDAR board clusters (ours). A LiDAR detector sees geometry
/// only: a cabinet's front or a door the size of a board passes every gate and the descriptor
/// when its base is out of sight. In a session where the boards move (still poses: the board is
/// carried from shot to shot), such an object betrays itself: it comes back at the same place
/// in the LiDAR frame while every board the camera sees has moved. The test needs no extrinsic,
/// since distances between two frames' positions are the same in both sensors' frames:
/// - two clusters of different frames are one object when their planes agree (normals within
///   `max_normal_angle_deg`, each centroid within `max_plane_distance_m` of the other's plane)
///   and their centroids lie within half the smallest board side (what occlusion moves them);
/// - the pair is evidence of scenery when every board seen by the camera in both frames moved by
///   more than the cluster did plus half that side, and evidence of a board when one did not;
/// - a cluster is scenery with evidence from at least `min_frames` other frames, outnumbering
///   the evidence of a board.
/// A moving vehicle moves everything in the LiDAR frame, so drives are left as they are; a
/// board standing still stays too.

#include <string>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/session/session_observations.hpp"

namespace calibd {

struct StaticSceneryConfig {
  bool enabled = true;
  double max_normal_angle_deg = 10.0;
  double max_plane_distance_m = 0.05;
  int min_frames = 2;

  /// False with `error` naming the bad field.
  bool IsValid(std::string* error) const;
};

struct StaticScenery {
  std::vector<char> scenery;  ///< per session.lidar entry
  int num_scenery = 0;
};

/// The clusters of `session` that are static scenery (none when disabled).
StaticScenery FindStaticScenery(const SessionObservations& session,
                                const std::vector<BoardGeometry>& boards,
                                const StaticSceneryConfig& config);

}  // namespace calibd
