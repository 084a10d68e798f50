#include "calibd/core/lidar/range_image.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

namespace {}  // namespace

float FastAtan2(float y, float x) {
  // atan on [0, 1] by an odd minimax polynomial (Abramowitz & Stegun 4.4.49 form), extended to
  // the full circle by octant symmetry.
  const float ax = std::fabs(x), ay = std::fabs(y);
  const float mx = std::max(ax, ay), mn = std::min(ax, ay);
  if (mx == 0.0f) return 0.0f;
  const float a = mn / mx;
  const float s = a * a;
  float r =
      a * (0.99997726f +
           s * (-0.33262347f +
                s * (0.19354346f + s * (-0.11643287f + s * (0.05265332f - 0.01172120f * s)))));
  if (ay > ax) r = static_cast<float>(M_PI_2) - r;
  if (x < 0.0f) r = static_cast<float>(M_PI) - r;
  return y < 0.0f ? -r : r;
}

void RangeImage::Configure(const LidarModel& model, double min_range_m, double max_range_m,
                           size_t max_points, double cell_range_tolerance_m) {
  cell_tolerance_ = static_cast<float>(cell_range_tolerance_m);
  has_rings_ = model.has_rings && !model.ring_elevation_deg.empty();
  min_range_ = static_cast<float>(min_range_m);
  max_range_ = static_cast<float>(max_range_m);
  az_step_rad_ = model.azimuth_resolution_deg * kDeg2Rad;
  const double fov_az_deg = model.azimuth_max_deg - model.azimuth_min_deg;
  wraps_ = fov_az_deg >= 360.0 - 1e-6;
  if (has_rings_) {
    // Columns centred on the firing angles -180 + k * step of a spinning sensor.
    cols_ = static_cast<int>(std::lround(fov_az_deg / model.azimuth_resolution_deg));
    az_min_rad_ = model.azimuth_min_deg * kDeg2Rad - 0.5 * az_step_rad_;
    const int n = static_cast<int>(model.ring_elevation_deg.size());
    std::vector<int> order(n);
    std::iota(order.begin(), order.end(), 0);
    std::stable_sort(order.begin(), order.end(), [&](int a, int b) {
      return model.ring_elevation_deg[a] < model.ring_elevation_deg[b];
    });
    rows_ = n;
    row_of_ring_.assign(n, 0);
    row_elevation_rad_.resize(n);
    for (int row = 0; row < n; ++row) {
      row_of_ring_[order[row]] = row;
      row_elevation_rad_[row] = static_cast<float>(model.ring_elevation_deg[order[row]] * kDeg2Rad);
    }
  } else {
    // Bins of the sensor's angular resolution: finer bins leave most of them empty, coarser ones
    // drop points that the sensor resolved (paper §III-C-1 keeps the nearest point of a bin).
    cols_ = std::max(1, static_cast<int>(std::ceil(fov_az_deg / model.azimuth_resolution_deg)));
    az_min_rad_ = model.azimuth_min_deg * kDeg2Rad;
    el_step_rad_ = model.elevation_resolution_deg * kDeg2Rad;
    el_min_rad_ = model.elevation_min_deg * kDeg2Rad;
    rows_ =
        std::max(1, static_cast<int>(std::ceil((model.elevation_max_deg - model.elevation_min_deg) /
                                               model.elevation_resolution_deg)));
    row_elevation_rad_.resize(rows_);
    for (int row = 0; row < rows_; ++row)
      row_elevation_rad_[row] = static_cast<float>(el_min_rad_ + (row + 0.5) * el_step_rad_);
  }
  row_spacing_rad_.assign(rows_, has_rings_ ? 0.0 : el_step_rad_);
  if (has_rings_) {
    for (int row = 0; row < rows_; ++row) {
      double gap = 0.0;
      if (row > 0)
        gap = std::max(gap, double{row_elevation_rad_[row] - row_elevation_rad_[row - 1]});
      if (row + 1 < rows_)
        gap = std::max(gap, double{row_elevation_rad_[row + 1] - row_elevation_rad_[row]});
      row_spacing_rad_[row] = gap;
    }
  }
  cells_.assign(static_cast<size_t>(rows_) * cols_, RangeImageCell{});
  point_cell_.assign(max_points, -1);
  next_point_.assign(max_points, -1);
}

int RangeImage::RowOfElevation(float elevation_rad) const {
  if (!has_rings_) {
    const int row = static_cast<int>(std::floor((elevation_rad - el_min_rad_) / el_step_rad_));
    return (row >= 0 && row < rows_) ? row : -1;
  }
  // Nearest ring by elevation (rows are sorted by elevation); outside the table by more than
  // half the outermost gap is outside the field of view.
  const auto it =
      std::lower_bound(row_elevation_rad_.begin(), row_elevation_rad_.end(), elevation_rad);
  int row = static_cast<int>(it - row_elevation_rad_.begin());
  if (row == rows_) {
    row = rows_ - 1;
  } else if (row > 0 && elevation_rad - row_elevation_rad_[row - 1] <
                            row_elevation_rad_[row] - elevation_rad) {
    row -= 1;
  }
  const double tolerance = 0.5 * row_spacing_rad_[row] + 1e-6;
  return std::fabs(elevation_rad - row_elevation_rad_[row]) <= tolerance ? row : -1;
}

bool RangeImage::CellOf(double azimuth_rad, double elevation_rad, int* row, int* col) const {
  const int r = RowOfElevation(static_cast<float>(elevation_rad));
  if (r < 0) return false;
  int c = static_cast<int>(std::floor((azimuth_rad - az_min_rad_) / az_step_rad_));
  if (wraps_) {
    c %= cols_;
    if (c < 0) c += cols_;
  } else if (c < 0 || c >= cols_) {
    return false;
  }
  *row = r;
  *col = c;
  return true;
}

bool RangeImage::CellBoxOf(double azimuth_lo, double azimuth_hi, double elevation_lo,
                           double elevation_hi, int* row_lo, int* row_hi, int* col_lo,
                           int* col_hi) const {
  // Rows' elevations grow with the row; the image spans half a gap beyond its outer rows.
  const double el_min = row_elevation_rad_[0] - 0.5 * row_spacing_rad_[0];
  const double el_max = row_elevation_rad_[rows_ - 1] + 0.5 * row_spacing_rad_[rows_ - 1];
  if (elevation_hi < el_min || elevation_lo > el_max) return false;
  const double el_lo = std::max(elevation_lo, double{row_elevation_rad_[0]});
  const double el_hi = std::min(elevation_hi, double{row_elevation_rad_[rows_ - 1]});
  double az_lo = azimuth_lo, az_hi = azimuth_hi;
  if (!wraps_) {
    const double az_max = az_min_rad_ + cols_ * az_step_rad_;
    if (azimuth_hi < az_min_rad_ || azimuth_lo > az_max) return false;
    // Inside the outer columns by a tenth of a step, so that the floor lands in them.
    az_lo = std::max(az_lo, az_min_rad_ + 0.1 * az_step_rad_);
    az_hi = std::min(az_hi, az_max - 0.1 * az_step_rad_);
  }
  int r = 0, c = 0;
  if (!CellOf(az_lo, el_lo, &r, &c)) return false;
  *row_lo = r;
  *col_lo = c;
  if (!CellOf(az_hi, el_hi, &r, &c)) return false;
  *row_hi = r;
  *col_hi = c;
  if (*row_lo > *row_hi) std::swap(*row_lo, *row_hi);
  return true;
}

void RangeImage::Build(const PointCloudView& cloud, RangeImageStats* stats) {
  *stats = RangeImageStats{};
  std::fill(cells_.begin(), cells_.end(), RangeImageCell{});
  const size_t n = std::min(cloud.size, point_cell_.size());
  stats->overflow_points = static_cast<int>(cloud.size - n);
  const float az_scale = static_cast<float>(1.0 / az_step_rad_);
  const float az_min = static_cast<float>(az_min_rad_);
  const int num_rings = static_cast<int>(row_of_ring_.size());
  for (size_t i = 0; i < n; ++i) {
    point_cell_[i] = -1;
    const float x = cloud.x[i], y = cloud.y[i], z = cloud.z[i];
    const float range = std::sqrt(x * x + y * y + z * z);
    // NaN and inf fail both comparisons or the finite check.
    if (!(range >= min_range_ && range <= max_range_) || !std::isfinite(range)) {
      ++stats->invalid_points;
      continue;
    }
    int row = -1;
    if (has_rings_ && cloud.ring != nullptr && cloud.ring[i] >= 0 && cloud.ring[i] < num_rings) {
      row = row_of_ring_[cloud.ring[i]];
    } else {
      row = RowOfElevation(FastAtan2(z, std::sqrt(x * x + y * y)));
    }
    int col = static_cast<int>(std::floor((FastAtan2(y, x) - az_min) * az_scale));
    if (wraps_) {
      if (col >= cols_) col -= cols_;
      if (col < 0) col += cols_;
    }
    if (row < 0 || col < 0 || col >= cols_) {
      ++stats->outside_points;
      continue;
    }
    const int index = CellIndex(row, col);
    RangeImageCell& c = cells_[index];
    point_cell_[i] = index;
    if (c.index >= 0 && c.range <= range) continue;  // keep the nearest point of the bin
    c.x = x;
    c.y = y;
    c.z = z;
    c.range = range;
    c.index = static_cast<int32_t>(i);
    c.num_points = 1;
  }
  // Second pass, now that each cell's nearest point is known: chain the cell's other points that
  // lie within the tolerance of it, drop the rest.
  for (size_t i = 0; i < n; ++i) {
    next_point_[i] = -1;
    const int index = point_cell_[i];
    if (index < 0) continue;
    RangeImageCell& c = cells_[index];
    if (c.index == static_cast<int32_t>(i)) continue;
    const float x = cloud.x[i], y = cloud.y[i], z = cloud.z[i];
    const float range = std::sqrt(x * x + y * y + z * z);
    if (range - c.range > cell_tolerance_ || !(cell_tolerance_ > 0.0f)) {
      ++stats->dropped_points;
      continue;
    }
    next_point_[i] = c.next_point;
    c.next_point = static_cast<int32_t>(i);
    ++c.num_points;
    ++stats->chained_points;
  }
}

int RangeImage::CellAt(int row, int col) const {
  if (row < 0 || row >= rows_) return -1;
  if (col < 0 || col >= cols_) {
    if (!wraps_) return -1;
    col = (col % cols_ + cols_) % cols_;
  }
  return CellIndex(row, col);
}

int RangeImage::NearestCell(int row, int col, int dr, int dc, int max_empty) const {
  for (int step = 1; step <= max_empty + 1; ++step) {
    const int idx = CellAt(row + dr * step, col + dc * step);
    if (idx < 0) return -1;
    if (cells_[idx].index >= 0) return idx;
  }
  return -1;
}

}  // namespace calibd
