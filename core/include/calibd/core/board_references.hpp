#pragma once
/// \file
/// Reference board clusters for descriptor matching (paper §III-C-2 and Fig. 2b: "reference
/// descriptors are calculated based on simulated marker board cloud clusters"). Pure geometry: the
/// beams of a LidarModel intersected with a noise-free board rectangle.

#include <Eigen/Core>
#include <vector>

#include "calibd/core/lidar_model.hpp"

namespace calibd {

/// Where a simulated board is. The board centre is at `distance_m` along the direction of
/// azimuth 0 and elevation `elevation_deg`; the board first faces the sensor, then turns by
/// `yaw_deg` about the vertical and `pitch_deg` about its own horizontal axis.
struct BoardView {
  double distance_m = 10.0;
  double elevation_deg = 0.0;
  double yaw_deg = 0.0;
  double pitch_deg = 0.0;
};

/// Intersects the beams of `model` with a width x height rectangle seen as `view`: for ring
/// LiDARs the ring elevations x azimuth steps (0, +-step, ...); for ringless ones the grid of
/// their azimuth and elevation resolution. Writes the hit points (LiDAR frame) into `points`.
void SimulateBoardCluster(const LidarModel& model, double width_m, double height_m,
                          const BoardView& view, std::vector<Eigen::Vector3f>* points);

/// The views the detector builds references from: distances 5, 8, 12, 18, 25 and 32 m, yaw and
/// pitch in {0, +-20, +-40} deg, at elevations 0 and -6 deg (a board below a roof LiDAR).
std::vector<BoardView> DefaultReferenceViews();

}  // namespace calibd
