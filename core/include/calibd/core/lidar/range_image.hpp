#pragma once
/// \file
/// Cylindrical range image of one LiDAR sweep (paper §III-C-1; Bogoslavskyi & Stachniss 2016,
/// §III-A). Row 0 is the lowest beam, rows grow upwards; columns grow with azimuth atan2(y, x).
///
/// - Ring LiDARs: one row per ring, rings ordered by their elevation in the model's table; one
///   column per azimuth step of the model, centred on the firing angles (-180 + k * step).
/// - Ringless (MEMS, polygon) LiDARs: rows and columns are bins of the model's elevation and
///   azimuth resolution over its field of view. MEMS patterns are not grids, so a bin may get
///   several points or none, and the segmentation steps over a few empty bins to find neighbours.
///
/// A cell shows its nearest point to the segmentation. The cell's other points within
/// `cell_range_tolerance_m` of it are chained to it (RangeImageCell::next_point, next_point()) so
/// that a cluster keeps all its points; farther ones (the wall seen past a board's edge) are
/// dropped (paper §III-C-1: "points that locate far in the frustum are removed"). Without the
/// chain a driving M1 loses up to 30% of a board's points at 20 m to shared bins.
///
/// All buffers are allocated by Configure(); Build() allocates nothing.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "calibd/core/common/image_view.hpp"
#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {

/// One cell of the range image: the kept point (LiDAR frame, m) and its range.
struct RangeImageCell {
  float x = 0.0f, y = 0.0f, z = 0.0f;
  float range = 0.0f;  ///< sqrt(x^2 + y^2 + z^2), m
  int32_t index = -1;  ///< index of the point in the input cloud, -1 for an empty cell
  /// First further point of the cell within the range tolerance (input index), -1 for none; the
  /// chain continues with RangeImage::next_point()[i] until -1.
  int32_t next_point = -1;
  int32_t num_points = 0;  ///< the kept point and the chained ones (0 for an empty cell)
};

/// What Build() did with the input points.
struct RangeImageStats {
  int invalid_points = 0;   ///< NaN/inf, or range outside [min_range, max_range]
  int outside_points = 0;   ///< finite and in range but outside the field of view
  int dropped_points = 0;   ///< farther than a cell's nearest point by more than the tolerance
  int chained_points = 0;   ///< further points of a cell within the tolerance, kept in its chain
  int overflow_points = 0;  ///< beyond the configured point capacity, not looked at
};

class RangeImage {
 public:
  /// Sizes the grid for `model` and the per-point cell map for `max_points` points. Further points
  /// of a cell within `cell_range_tolerance_m` of its nearest are chained to it (0: none).
  void Configure(const LidarModel& model, double min_range_m, double max_range_m, size_t max_points,
                 double cell_range_tolerance_m = 0.0);

  /// Projects `cloud` into the image (clearing it first). Allocates nothing.
  void Build(const PointCloudView& cloud, RangeImageStats* stats);

  int rows() const { return rows_; }
  /// True for a ring LiDAR (a row per ring), false for elevation bins.
  bool has_rings() const { return has_rings_; }
  int cols() const { return cols_; }
  /// True when the columns cover 360 degrees, so column cols()-1 neighbours column 0.
  bool wraps() const { return wraps_; }
  /// Cells are stored column by column (a column's rows are contiguous): the ground walk goes up
  /// columns, and a spinning LiDAR delivers its points column by column.
  int CellIndex(int row, int col) const { return col * rows_ + row; }
  int RowOf(int index) const { return index % rows_; }
  int ColOf(int index) const { return index / rows_; }
  const RangeImageCell& cell(int row, int col) const { return cells_[CellIndex(row, col)]; }
  const RangeImageCell& cell(int index) const { return cells_[index]; }
  /// The index of cell (row, col), -1 outside the image; columns wrap for 360-degree sensors.
  int CellAt(int row, int col) const;
  /// The first non-empty cell from (row, col) in direction (dr, dc), stepping over at most
  /// `max_empty` empty cells; -1 past the image's edge (columns wrap for 360-degree sensors).
  int NearestCell(int row, int col, int dr, int dc, int max_empty) const;
  /// Cell index of each input point of the last Build(), -1 when it was skipped. The point is the
  /// cell's kept (nearest) one when cell(point_cell()[i]).index == i.
  const std::vector<int32_t>& point_cell() const { return point_cell_; }
  /// Chain of each cell's further points: next_point()[i] follows input point i, -1 ends it.
  const std::vector<int32_t>& next_point() const { return next_point_; }

  /// Row and column of a direction (radians), or false outside the image. For ring LiDARs the row
  /// is that of the ring with the nearest elevation.
  bool CellOf(double azimuth_rad, double elevation_rad, int* row, int* col) const;
  /// The cells that the directions in [azimuth_lo, azimuth_hi] x [elevation_lo, elevation_hi]
  /// (radians) fall in, clipped to the image: false when none does. Columns are not unwrapped:
  /// for a 360-degree image a box across the seam gives col_lo > col_hi.
  bool CellBoxOf(double azimuth_lo, double azimuth_hi, double elevation_lo, double elevation_hi,
                 int* row_lo, int* row_hi, int* col_lo, int* col_hi) const;
  /// Angular size of a column, radians.
  double azimuth_step_rad() const { return az_step_rad_; }
  /// Elevation of a row (ring elevation or bin centre), radians.
  double row_elevation_rad(int row) const { return row_elevation_rad_[row]; }
  /// Elevation gap to the next row (the larger of the gaps above and below), radians.
  double row_spacing_rad(int row) const { return row_spacing_rad_[row]; }

 private:
  int RowOfElevation(float elevation_rad) const;

  int rows_ = 0, cols_ = 0;
  bool wraps_ = false;
  bool has_rings_ = false;
  double az_min_rad_ = 0.0, az_step_rad_ = 0.0;
  double el_min_rad_ = 0.0, el_step_rad_ = 0.0;  // ringless bins
  float min_range_ = 0.0f, max_range_ = 0.0f;
  float cell_tolerance_ = 0.0f;
  std::vector<int> row_of_ring_;          // ring index -> row (ring LiDARs)
  std::vector<float> row_elevation_rad_;  // elevation of each row (ring) or bin centre
  std::vector<double> row_spacing_rad_;   // see row_spacing_rad()
  std::vector<RangeImageCell> cells_;     // rows_ * cols_
  std::vector<int32_t> point_cell_;       // capacity max_points
  std::vector<int32_t> next_point_;       // capacity max_points
};

/// atan2 with a polynomial (max error about 1e-5 rad), several times faster than std::atan2;
/// well below the 0.075 deg (1.3e-3 rad) finest bin of the supported LiDARs.
float FastAtan2(float y, float x);

}  // namespace calibd
