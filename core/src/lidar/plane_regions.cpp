#include "calibd/core/lidar/plane_regions.hpp"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>

namespace calibd {

namespace {

// The 4-neighbourhood: left, right, down, up.
constexpr int kDr[4] = {0, 0, -1, 1}, kDc[4] = {-1, 1, 0, 0};
// A local plane's window is sampled at most this many rows and columns each way.
constexpr int kHalfSamples = 3;
// A local plane needs this many cells of the cluster in its window.
constexpr int kMinWindowCells = 6;
// A region's plane is refitted from its cells once the second principal variance exceeds the
// third by this factor: before that (a single scan line, a thin strip) the fit cannot tell the
// plane's tilt about the strip's axis, and the seed's plane is kept.
constexpr double kWellPosedRatio = 9.0;
// A cell of the cluster beyond a region's edge is attached to it within this many growing
// tolerances of its plane (the surface goes on, bent or broken by noise); farther, the edge is a
// step to another surface.
constexpr float kJumpTolerances = 3.0f;

// Sums of points for a plane fit.
struct PlaneSums {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  Eigen::Matrix3d outer = Eigen::Matrix3d::Zero();
  int count = 0;

  void Add(const Eigen::Vector3f& p) {
    const Eigen::Vector3d q = p.cast<double>();
    sum += q;
    outer.noalias() += q * q.transpose();
    ++count;
  }

  // Centroid, unit normal (smallest principal axis) and the three variances, ascending.
  void Fit(Eigen::Vector3d* centroid, Eigen::Vector3d* normal, Eigen::Vector3d* variances) const {
    *centroid = sum / count;
    const Eigen::Matrix3d cov = outer / count - *centroid * centroid->transpose();
    Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig;
    eig.computeDirect(cov);
    *normal = eig.eigenvectors().col(0);
    *variances = eig.eigenvalues().cwiseMax(0.0);
  }
};

}  // namespace

void PlaneRegions::Configure(const RangeImage& image, const PlaneRegionConfig& config) {
  config_ = config;
  const size_t cells = static_cast<size_t>(image.rows()) * image.cols();
  local_.assign(cells, -1);
  cell_region_.assign(cells, 0);
  cells_.resize(cells);
  row_min_.assign(image.rows(), 0);
  row_max_.assign(image.rows(), 0);
  row_cols_.assign(image.rows(), 0);
  touched_rows_.assign(image.rows(), 0);
  released_.resize(cells);
  normals_.resize(cells);
  centers_.resize(cells);
  flatness_.resize(cells);
  sorted_.resize(cells);
  seeds_.resize(cells);
  region_of_.resize(cells);
  members_.resize(cells);
  regions_.resize(cells / std::max(1, config.min_region_cells) + 1);
  num_cells_ = num_regions_ = 0;
}

int PlaneRegions::SeedStride(const RangeImage& image, int32_t cell) const {
  if (config_.min_board_area_m2 <= 0.0) return 1;
  const double range = std::max(0.1f, image.cell(cell).range);
  const double cell_sr = image.azimuth_step_rad() * image.row_spacing_rad(image.RowOf(cell));
  const double board_cells = config_.min_board_area_m2 / (range * range * cell_sr);
  return std::max(1, static_cast<int>(board_cells / config_.seeds_per_board));
}

bool PlaneRegions::LocalPlane(const RangeImage& image, const Eigen::Vector3f* points, int32_t cell,
                              Eigen::Vector3f* normal, Eigen::Vector3f* center,
                              float* flatness) const {
  const int row = image.RowOf(cell), col = image.ColOf(cell);
  // window_half_m each way at the cell's range, at least one beam spacing: the plane's normal
  // needs an extent well above the range noise (a VLP-32C's 0.33 deg rings are 2 cm apart at
  // 3.5 m, its noise as much). Sampled at most 2 kHalfSamples + 1 rows and columns wide.
  const double row_spacing = image.row_spacing_rad(row), az_step = image.azimuth_step_rad();
  const double h = std::max(
      {row_spacing, az_step, config_.window_half_m / std::max(1e-3f, image.cell(cell).range)});
  const int half_rows = std::max(1, static_cast<int>(std::lround(h / row_spacing)));
  const int half_cols = std::max(1, static_cast<int>(std::lround(h / az_step)));
  const int row_step = std::max(1, half_rows / kHalfSamples);
  const int col_step = std::max(1, half_cols / kHalfSamples);
  for (int scale = 1; scale <= 2; ++scale) {  // wider where the pattern leaves cells empty
    const int rows = (half_rows / row_step) * scale, cols = (half_cols / col_step) * scale;
    PlaneSums sums;
    int row_lo = rows, row_hi = -rows, col_lo = cols, col_hi = -cols;
    for (int i = -rows; i <= rows; ++i) {
      for (int j = -cols; j <= cols; ++j) {
        const int idx = image.CellAt(row + i * row_step, col + j * col_step);
        if (idx < 0) continue;
        const int32_t l = local_[idx];
        if (l < 0) continue;
        sums.Add(points[l]);
        row_lo = std::min(row_lo, i);
        row_hi = std::max(row_hi, i);
        col_lo = std::min(col_lo, j);
        col_hi = std::max(col_hi, j);
      }
    }
    if (sums.count < kMinWindowCells || row_lo == row_hi || col_lo == col_hi) continue;
    Eigen::Vector3d centroid, n, variances;
    sums.Fit(&centroid, &n, &variances);
    *normal = n.cast<float>();
    *center = centroid.cast<float>();
    // The residual variance of a plane fitted to N points underestimates the noise's by
    // (N - 3) / N (three parameters fitted).
    *flatness = static_cast<float>(std::sqrt(variances(0) * sums.count / (sums.count - 3)));
    return true;
  }
  return false;
}

int PlaneRegions::Grow(const RangeImage& image, const Eigen::Vector3f* points, int k, int32_t label,
                       int tail, float tolerance, PlaneRegion* region) {
  // The seed's window plane (through the window's centroid: the seed's own point is off the
  // plane by its noise).
  Eigen::Vector3f normal = normals_[k], center = centers_[k];
  PlaneSums sums;
  int next_fit = kMinWindowCells;
  int head = tail;
  region_of_[k] = label;
  members_[tail++] = k;
  sums.Add(points[k]);
  while (head < tail) {
    const int32_t cell = cells_[members_[head++]];
    const int row = image.RowOf(cell), col = image.ColOf(cell);
    for (int d = 0; d < 4; ++d) {
      const int idx = image.NearestCell(row, col, kDr[d], kDc[d], config_.neighbor_search_cells);
      if (idx < 0) continue;
      const int32_t j = local_[idx];
      if (j < 0 || region_of_[j] != 0) continue;
      if (std::fabs(normal.dot(points[j] - center)) > tolerance) continue;
      region_of_[j] = label;
      members_[tail++] = j;
      sums.Add(points[j]);
    }
    if (sums.count >= next_fit) {
      next_fit = 2 * sums.count;
      Eigen::Vector3d c, n, variances;
      sums.Fit(&c, &n, &variances);
      if (variances(1) > kWellPosedRatio * variances(0)) {
        normal = n.cast<float>();
        center = c.cast<float>();
      }
    }
  }
  region->end = tail;
  region->normal = normal;
  region->center = center;
  return tail;
}

double PlaneRegions::AttachedFraction(const RangeImage& image, const Eigen::Vector3f* points,
                                      int i) const {
  const PlaneRegion& region = regions_[i];
  const int32_t label = region.label;
  const float jump = kJumpTolerances * tolerance_;
  int attached = 0, edges = 0;
  for (int m = region.begin; m < region.end; ++m) {
    const int32_t cell = cells_[members_[m]];
    const int row = image.RowOf(cell), col = image.ColOf(cell);
    for (int d = 0; d < 4; ++d) {
      const int idx = image.NearestCell(row, col, kDr[d], kDc[d], config_.neighbor_search_cells);
      const int32_t j = idx < 0 ? -1 : local_[idx];
      if (j >= 0 && region_of_[j] == label) continue;  // inside
      ++edges;
      if (j >= 0 && std::fabs(region.normal.dot(points[j] - region.center)) < jump) ++attached;
    }
  }
  return edges == 0 ? 0.0 : static_cast<double>(attached) / edges;
}

int PlaneRegions::Extract(const RangeImage& image, const int32_t* cells,
                          const Eigen::Vector3f* points, int n) {
  for (int k = 0; k < num_cells_; ++k) {
    local_[cells_[k]] = -1;
    cell_region_[cells_[k]] = 0;
  }
  num_cells_ = n;
  num_regions_ = 0;
  noise_m_ = 0.0;
  for (int k = 0; k < n; ++k) {
    cells_[k] = cells[k];
    local_[cells[k]] = k;
    region_of_[k] = 0;
    released_[k] = 0;
  }
  // Local planes on about seeds_per_board cells of any board-sized area: every cell of a board
  // far away, one in a hundred of a dense LiDAR's near walls (cells come in breadth-first order,
  // so every stride-th cell spreads over the cluster). The cost then follows the scene's
  // objects, not its cells.
  int num_seeds = 0;
  for (int k = 0; k < n; ++k) flatness_[k] = -1.0f;
  for (int k = 0; k < n; ++k) {
    if (k % SeedStride(image, cells[k]) != 0) continue;
    if (LocalPlane(image, points, cells[k], &normals_[k], &centers_[k], &flatness_[k])) {
      sorted_[num_seeds] = flatness_[k];
      seeds_[num_seeds++] = k;
    }
  }
  if (num_seeds == 0) return 0;
  const int median = num_seeds / 2;
  std::nth_element(sorted_.begin(), sorted_.begin() + median, sorted_.begin() + num_seeds);
  noise_m_ = sorted_[median];
  tolerance_ =
      static_cast<float>(std::max(config_.distance_sigmas * noise_m_, config_.min_distance_m));
  const float tolerance = tolerance_;
  // Seeds: flattest first, and only cells whose window is about as flat as the noise (a window
  // across an edge fits two surfaces badly and would seed a plane that is neither).
  const float max_seed_flatness = static_cast<float>(config_.distance_sigmas * noise_m_);
  std::sort(seeds_.begin(), seeds_.begin() + num_seeds,
            [&](int32_t a, int32_t b) { return flatness_[a] < flatness_[b]; });
  int tail = 0;
  int32_t label = 0;
  for (int s = 0; s < num_seeds; ++s) {
    const int32_t k = seeds_[s];
    if (region_of_[k] != 0 || released_[k]) continue;
    if (flatness_[k] > max_seed_flatness) break;
    PlaneRegion region;
    region.begin = tail;
    tail = Grow(image, points, k, ++label, tail, tolerance, &region);
    tail = region.end = PruneThinRows(image, region);
    if (region.size() < config_.min_region_cells) {
      for (int m = region.begin; m < region.end; ++m) Release(members_[m]);
      tail = region.begin;
      continue;
    }
    region.label = label;
    regions_[num_regions_] = region;
    ++num_regions_;
    for (int m = region.begin; m < tail; ++m) cell_region_[cells_[members_[m]]] = num_regions_;
  }
  return num_regions_;
}

int PlaneRegions::PruneThinRows(const RangeImage& image, const PlaneRegion& region) {
  if (region.size() == 0) return region.end;
  int touched = 0;
  for (int m = region.begin; m < region.end; ++m) {
    const int32_t cell = cells_[members_[m]];
    const int row = image.RowOf(cell), col = image.ColOf(cell);
    if (row_cols_[row] == 0) {
      touched_rows_[touched++] = row;
      row_min_[row] = row_max_[row] = col;
    }
    ++row_cols_[row];
    row_min_[row] = std::min(row_min_[row], col);
    row_max_[row] = std::max(row_max_[row], col);
  }
  // Widths at the region's range (a wrapped row looks wide and stays).
  const double m_per_col = image.azimuth_step_rad() * region.center.norm();
  int end = region.begin;
  for (int m = region.begin; m < region.end; ++m) {
    const int32_t k = members_[m];
    const int row = image.RowOf(cells_[k]);
    if ((row_max_[row] - row_min_[row] + 1) * m_per_col < config_.min_row_width_m) {
      Release(k);
      continue;
    }
    members_[end++] = k;
  }
  for (int t = 0; t < touched; ++t) row_cols_[touched_rows_[t]] = 0;
  return end;
}

}  // namespace calibd
