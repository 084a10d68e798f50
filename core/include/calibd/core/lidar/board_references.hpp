#pragma once
/// \file
/// Reference board clusters for descriptor matching (paper §III-C-2 and Fig. 2b: "reference
/// descriptors are calculated based on simulated marker board cloud clusters"). Pure geometry: the
/// beams of a LidarModel intersected with a board rectangle, at a chosen phase of the beam grid,
/// plus the sensor's range noise when asked (AddRangeNoise).

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {

/// Where a simulated board is. The board centre is at `distance_m` along the direction of
/// azimuth 0 and elevation `elevation_deg`; the board first faces the sensor, then turns by
/// `yaw_deg` about the vertical and `pitch_deg` about its own horizontal axis.
struct BoardView {
  double distance_m = 10.0;
  double elevation_deg = 0.0;
  double yaw_deg = 0.0;
  double pitch_deg = 0.0;
  /// Where the beam grid falls on the board, as fractions of one step (any value; [-0.5, 0.5)
  /// covers every phase). A real board sits at any phase, and a sparse far board looks different
  /// at each: 7 columns or 8. Azimuth: the columns are at (k + azimuth_phase) * step. Elevation:
  /// for ringless models the rows are at elevation_deg + (j + elevation_phase) * step; for ring
  /// models the board moves up by elevation_phase times the ring gap at its elevation.
  double azimuth_phase = 0.0;
  double elevation_phase = 0.0;
};

/// Intersects the beams of `model` with a width x height rectangle seen as `view`: for ring
/// LiDARs the ring elevations x azimuth steps; for ringless ones the grid of their azimuth and
/// elevation resolution (both shifted by the view's phases); for non-repetitive ones
/// (LidarModel::non_repetitive) beams drawn at random at the pattern's density, one mean point
/// per range-image cell hit (the phases shift the cells and seed the draw). Writes the hit points
/// (LiDAR frame, noise-free) into `points` and, if `weights` is not null, the elevation gap each
/// beam stands for (half the gap between its neighbouring rows, rad), as LidarDetector weighs real
/// clusters (LidarDetectorConfig::weight_by_sample_area).
void SimulateBoardCluster(const LidarModel& model, double width_m, double height_m,
                          const BoardView& view, std::vector<Eigen::Vector3f>* points,
                          std::vector<float>* weights = nullptr);

/// Moves each point along its beam by Gaussian noise of `sigma_m` (the sensor's range noise).
/// Deterministic for a given `seed` (std::mt19937_64 and a Box-Muller transform of our own, so
/// the result does not depend on the standard library).
void AddRangeNoise(double sigma_m, uint64_t seed, std::vector<Eigen::Vector3f>* points);

/// The views the detector builds references from: distances 2, 3.5, 5, 8, 12, 18, 25 and 32 m
/// (workshops and labs place boards from 1.5 m), yaw and pitch in {0, +-20, +-40} deg, at
/// elevations 0 and -6 deg (a board below a roof LiDAR).
std::vector<BoardView> DefaultReferenceViews();

}  // namespace calibd
