#pragma once
/// \file
/// Whether a ring LiDAR's lasers fire at the elevations of its model's table, from the boards
/// (residual structure per ring). A laser that fires delta above its table's
/// elevation puts its points, reported along the table's direction, r delta away from where
/// they are, along the elevation direction e_el; on a board of normal n that moves them off the
/// board's plane by r delta (n . e_el). Per ring, over every observation:
///   d = delta_ring g,   g = r (n . e_el)
/// with d a point's distance to its board's plane (the board pose refined with the LiDAR's
/// planes, so what all rings share is already taken up by the plane), fitted by least squares;
/// the sigma is the larger of the least-squares one and one from the scatter of the ring's
/// per-observation fits (errors shared by the points of one observation). What the rings share
/// is a board or pose effect, not a laser's: the check looks at each ring's delta about the
/// rings' weighted mean.

#include <limits>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/board_observation.hpp"

namespace calibd {

struct RingElevationCheck {
  bool measured = false;  ///< a ring LiDAR with at least kMinRingsMeasured rings measured
  int rings = 0;          ///< rings with a determined delta
  /// RMS over the measured rings of delta about their weighted mean, deg; and the mean of
  /// ((delta - mean) / sigma)^2, ~1 for lasers at their table's elevations.
  double rms_deg = 0.0;
  double chi2_per_ring = 0.0;
  int worst_ring = -1;  ///< the ring furthest from the mean in its sigmas (its row)
  double worst_deg = 0.0, worst_sigma_deg = std::numeric_limits<double>::infinity();
};

/// `projection` gives each point's ring (RangeImage::CellOf, a ring LiDAR's rows); a ringless
/// projection measures nothing. `T_camera_board` as in EstimateBoardBends.
RingElevationCheck CheckRingElevations(const std::vector<BoardGeometry>& boards,
                                       const ObservationSet& set, const RangeImage& projection,
                                       const Pose& T_camera_lidar,
                                       const std::vector<Pose>& T_camera_board);

}  // namespace calibd
