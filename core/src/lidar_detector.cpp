#include "calibd/core/lidar_detector.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>

#include "calibd/core/board_references.hpp"
#include "calibd/core/cluster_pca.hpp"
#include "calibd/core/m2dp.hpp"
#include "calibd/core/range_image.hpp"
#include "calibd/core/segmentation.hpp"

namespace calibd {

namespace {

constexpr double kDegToRad = M_PI / 180.0;

using Clock = std::chrono::steady_clock;

double Ms(Clock::time_point a, Clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Zero mean, unit norm: the Pearson correlation (paper Eq. 1) of two such vectors is their dot
// product. False for a constant vector.
bool Standardize(float* d, int n) {
  double mean = 0.0;
  for (int i = 0; i < n; ++i) mean += d[i];
  mean /= n;
  double ss = 0.0;
  for (int i = 0; i < n; ++i) ss += (d[i] - mean) * (d[i] - mean);
  if (!(ss > 0.0)) return false;
  const double inv = 1.0 / std::sqrt(ss);
  for (int i = 0; i < n; ++i) d[i] = static_cast<float>((d[i] - mean) * inv);
  return true;
}

}  // namespace

bool LidarDetectorConfig::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(segmentation_angle_deg > 0.0 && segmentation_angle_deg < 90.0))
    return fail("segmentation_angle_deg: must be in (0, 90)");
  if (!(ground_angle_deg >= 0.0 && ground_angle_deg < 90.0))
    return fail("ground_angle_deg: must be in [0, 90)");
  if (!(ground_max_step_m >= 0.0)) return fail("ground_max_step_m: must be >= 0");
  if (!(min_range_m >= 0.0)) return fail("min_range_m: must be >= 0");
  if (!(max_range_m > min_range_m)) return fail("max_range_m: must exceed min_range_m");
  if (neighbor_search_cells < 0 || neighbor_search_cells > 16)
    return fail("neighbor_search_cells: must be in 0..16");
  if (!(min_row_width_fraction >= 0.0 && min_row_width_fraction < 1.0))
    return fail("min_row_width_fraction: must be in [0, 1)");
  if (min_cluster_points < 3) return fail("min_cluster_points: must be >= 3");
  if (!(extent_tolerance >= 0.0 && extent_tolerance < 1.0))
    return fail("extent_tolerance: must be in [0, 1)");
  if (!(size_tolerance >= 0.0 && size_tolerance < 1.0))
    return fail("size_tolerance: must be in [0, 1)");
  if (!(max_planarity > 0.0)) return fail("max_planarity: must be > 0");
  if (!(max_board_tilt_deg > 0.0 && max_board_tilt_deg <= 90.0))
    return fail("max_board_tilt_deg: must be in (0, 90]");
  if (m2dp_elevations < 1 || m2dp_elevations > 64) return fail("m2dp_elevations: must be in 1..64");
  if (m2dp_azimuths < 1 || m2dp_azimuths > 64) return fail("m2dp_azimuths: must be in 1..64");
  if (m2dp_rings < 1 || m2dp_rings > 64) return fail("m2dp_rings: must be in 1..64");
  if (m2dp_sectors < 1 || m2dp_sectors > 64) return fail("m2dp_sectors: must be in 1..64");
  if (max_descriptor_points < min_cluster_points)
    return fail("max_descriptor_points: must be >= min_cluster_points");
  if (!(match_threshold >= 0.0 && match_threshold <= 1.0))
    return fail("match_threshold: must be in [0, 1]");
  if (max_clusters < 1) return fail("max_clusters: must be >= 1");
  if (max_boards < 1) return fail("max_boards: must be >= 1");
  if (max_board_points < 1) return fail("max_board_points: must be >= 1");
  if (max_points < 0) return fail("max_points: must be >= 0 (0: from the LiDAR model)");
  return true;
}

struct LidarDetector::Impl {
  LidarDetectorConfig config;
  LidarModel model;
  std::vector<BoardGeometry> boards;
  bool ok = false;
  std::string error;

  RangeImage image;
  RangeSegmenter segmenter;
  M2dp m2dp;
  Eigen::MatrixXf references;  // one standardized descriptor per column
  int num_references = 0;
  double min_side_m = 0.0;

  // Per-cluster scratch, sized once.
  std::vector<Eigen::Vector3f> cluster_points;
  std::vector<Eigen::Vector3f> aligned;
  Eigen::VectorXf descriptor;
  Eigen::VectorXf scores;

  Impl(const LidarDetectorConfig& c, const LidarModel& m) : config(c), model(m), m2dp(M2dpOf(c)) {}

  static M2dpConfig M2dpOf(const LidarDetectorConfig& c) {
    M2dpConfig m;
    m.elevations = c.m2dp_elevations;
    m.azimuths = c.m2dp_azimuths;
    m.rings = c.m2dp_rings;
    m.sectors = c.m2dp_sectors;
    return m;
  }

  // Standardized descriptor of `n` LiDAR-frame points into `descriptor`; false if degenerate.
  bool Describe(const Eigen::Vector3f* points, int n, const ClusterPca& pca) {
    // Even subsample of large clusters (the bin counts need the shape, not every point).
    const int m = std::min(n, config.max_descriptor_points);
    for (int k = 0; k < m; ++k) {
      const int i = static_cast<int>((static_cast<long long>(k) * n) / m);
      aligned[k] = pca.axes.transpose().cast<float>() * (points[i] - pca.centroid.cast<float>());
    }
    if (!m2dp.Compute(aligned.data(), m, descriptor.data())) return false;
    return Standardize(descriptor.data(), m2dp.size());
  }

  double BestScore() {
    if (num_references == 0) return 0.0;
    scores.noalias() = references.transpose() * descriptor;
    // Negative correlations are neglected (paper §III-C-2).
    return std::max(0.0, static_cast<double>(scores.maxCoeff()));
  }

  bool PassesGates(const ClusterPca& pca, int n, double beam_spacing_rad) const {
    if (n < config.min_cluster_points) return false;
    if (pca.planarity() > config.max_planarity) return false;
    // Upright: the normal's angle above the horizontal plane.
    const double tilt = std::asin(std::min(1.0, std::fabs(pca.axes(2, 2)))) / kDegToRad;
    if (tilt > config.max_board_tilt_deg) return false;
    const double spacing = pca.centroid.norm() * beam_spacing_rad;
    const double tol = config.extent_tolerance;
    const double size = std::sqrt(std::max(0.0, pca.eigenvalues(0) + pca.eigenvalues(1)));
    const double size_tol = config.size_tolerance;
    for (const BoardGeometry& g : boards) {
      const double lo = (1.0 - tol) * std::min(g.width_m, g.height_m) - spacing;
      const double hi = (1.0 + tol) * std::hypot(g.width_m, g.height_m) + spacing;
      if (pca.extents(0) > hi || pca.extents(1) > hi || pca.extents(0) < lo || pca.extents(1) < lo)
        continue;
      // RMS size of a uniformly sampled w x h rectangle: sqrt((w^2 + h^2) / 12).
      const double full = std::sqrt((g.width_m * g.width_m + g.height_m * g.height_m) / 12.0);
      if (size >= (1.0 - size_tol) * full - 0.5 * spacing && size <= (1.0 + size_tol) * full)
        return true;
    }
    return false;
  }

  void BuildReferences() {
    std::vector<Eigen::Vector3f> pts;
    std::vector<std::vector<float>> descs;
    std::vector<std::pair<double, double>> sizes;
    for (const BoardGeometry& g : boards) {
      const std::pair<double, double> s(g.width_m, g.height_m);
      if (std::find(sizes.begin(), sizes.end(), s) != sizes.end()) continue;
      sizes.push_back(s);
      for (const BoardView& v : DefaultReferenceViews()) {
        SimulateBoardCluster(model, g.width_m, g.height_m, v, &pts);
        const int n = static_cast<int>(pts.size());
        if (n < config.min_cluster_points) continue;
        ClusterPca pca;
        ComputeClusterPca(pts.data(), n, &pca);
        if (!Describe(pts.data(), n, pca)) continue;
        descs.emplace_back(descriptor.data(), descriptor.data() + descriptor.size());
      }
    }
    num_references = static_cast<int>(descs.size());
    references.resize(m2dp.size(), num_references);
    for (int r = 0; r < num_references; ++r)
      references.col(r) = Eigen::Map<const Eigen::VectorXf>(descs[r].data(), m2dp.size());
    scores.resize(num_references);
  }
};

LidarDetector::LidarDetector(const LidarDetectorConfig& config, const LidarModel& model,
                             const std::vector<BoardGeometry>& boards)
    : impl_(std::make_unique<Impl>(config, model)) {
  Impl& d = *impl_;
  if (!config.IsValid(&d.error)) return;
  if (boards.empty()) {
    d.error = "boards: at least one board is needed";
    return;
  }
  for (const BoardGeometry& g : boards) {
    std::string e;
    if (!g.IsValid(&e)) {
      d.error = "boards: " + e;
      return;
    }
  }
  if (!(model.azimuth_resolution_deg > 0.0) ||
      (!model.has_rings && !(model.elevation_resolution_deg > 0.0)) ||
      !(model.azimuth_max_deg > model.azimuth_min_deg) ||
      (model.has_rings && model.ring_elevation_deg.empty())) {
    d.error = "lidar model: needs positive resolutions, a field of view and, with rings, a table";
    return;
  }
  d.boards = boards;
  d.min_side_m = 1e300;
  for (const BoardGeometry& g : boards)
    d.min_side_m = std::min({d.min_side_m, g.width_m, g.height_m});
  const size_t max_points =
      config.max_points > 0
          ? static_cast<size_t>(config.max_points)
          : 2 * static_cast<size_t>(std::max(model.nominal_points_per_frame, 100000));
  d.image.Configure(model, config.min_range_m, config.max_range_m, max_points);
  SegmentationConfig sc;
  sc.ground_angle_deg = config.ground_angle_deg;
  sc.ground_max_step_m = config.ground_max_step_m;
  sc.segmentation_angle_deg = config.segmentation_angle_deg;
  sc.neighbor_search_cells = config.neighbor_search_cells;
  sc.min_cluster_points = config.min_cluster_points;
  sc.min_row_width_m = config.min_row_width_fraction * d.min_side_m;
  d.segmenter.Configure(d.image, sc);
  d.cluster_points.resize(static_cast<size_t>(d.image.rows()) * d.image.cols());
  d.aligned.resize(config.max_descriptor_points);
  d.descriptor.resize(d.m2dp.size());
  d.BuildReferences();
  if (d.num_references == 0) {
    d.error = "boards: no reference cluster has min_cluster_points points for this LiDAR model";
    return;
  }
  d.ok = true;
}

LidarDetector::~LidarDetector() = default;

bool LidarDetector::ok() const { return impl_->ok; }
const std::string& LidarDetector::error() const { return impl_->error; }
int LidarDetector::num_references() const { return impl_->num_references; }

double LidarDetector::ScoreCluster(const std::vector<Eigen::Vector3f>& points) {
  Impl& d = *impl_;
  if (!d.ok || points.size() < 3) return 0.0;
  ClusterPca pca;
  ComputeClusterPca(points.data(), static_cast<int>(points.size()), &pca);
  if (!d.Describe(points.data(), static_cast<int>(points.size()), pca)) return 0.0;
  return d.BestScore();
}

void LidarDetector::Detect(const PointCloudView& cloud, LidarDetections* out) {
  Impl& d = *impl_;
  const LidarDetectorConfig& c = d.config;
  // Capacities are reserved on the first use of `out`; later calls only clear and refill.
  const size_t point_capacity = static_cast<size_t>(c.max_boards) * c.max_board_points;
  if (out->boards.capacity() < static_cast<size_t>(c.max_boards)) out->boards.reserve(c.max_boards);
  if (out->points.capacity() < point_capacity) out->points.reserve(point_capacity);
  if (out->point_indices.capacity() < point_capacity) out->point_indices.reserve(point_capacity);
  if (out->candidates.capacity() < static_cast<size_t>(c.max_clusters))
    out->candidates.reserve(c.max_clusters);
  out->boards.clear();
  out->points.clear();
  out->point_indices.clear();
  out->candidates.clear();
  out->invalid_points = out->outside_points = out->dropped_points = out->overflow_points = 0;
  out->num_clusters = out->dropped_candidates = out->dropped_boards = 0;
  out->times = LidarStageTimes{};
  if (!d.ok) return;

  const Clock::time_point t0 = Clock::now();
  RangeImageStats stats;
  d.image.Build(cloud, &stats);
  out->invalid_points = stats.invalid_points;
  out->outside_points = stats.outside_points;
  out->dropped_points = stats.dropped_points;
  out->overflow_points = stats.overflow_points;
  const Clock::time_point t1 = Clock::now();
  d.segmenter.LabelGround(d.image);
  const Clock::time_point t2 = Clock::now();
  d.segmenter.Cluster(d.image);
  out->num_clusters = d.segmenter.num_segments();
  const Clock::time_point t3 = Clock::now();

  const int32_t* members = d.segmenter.members();
  for (int s = 0; s < d.segmenter.num_segments(); ++s) {
    const Segment& seg = d.segmenter.segment(s);
    const int n = seg.size();
    double spacing_sum = 0.0;
    for (int k = 0; k < n; ++k) {
      const RangeImageCell& cell = d.image.cell(members[seg.begin + k]);
      d.cluster_points[k] = Eigen::Vector3f(cell.x, cell.y, cell.z);
      spacing_sum += d.image.row_spacing_rad(d.image.RowOf(members[seg.begin + k]));
    }
    const double beam_spacing = std::max(d.image.azimuth_step_rad(), spacing_sum / n);
    ClusterPca pca;
    ComputeClusterPca(d.cluster_points.data(), n, &pca);
    if (!d.PassesGates(pca, n, beam_spacing)) continue;
    if (static_cast<int>(out->candidates.size()) >= c.max_clusters) {
      ++out->dropped_candidates;
      continue;
    }
    const double score = d.Describe(d.cluster_points.data(), n, pca) ? d.BestScore() : 0.0;
    LidarCandidate cand;
    cand.centroid = pca.centroid;
    cand.score = score;
    cand.num_points = n;
    cand.extents = pca.extents;
    cand.planarity = pca.planarity();
    cand.eigenvalues = pca.eigenvalues;
    out->candidates.push_back(cand);
    if (score < c.match_threshold) continue;
    if (static_cast<int>(out->boards.size()) >= c.max_boards) {
      ++out->dropped_boards;
      continue;
    }
    BoardCluster board;
    board.centroid = pca.centroid;
    board.normal = pca.axes.col(2);
    if (board.normal.dot(pca.centroid) > 0.0) board.normal = -board.normal;  // towards the sensor
    board.score = score;
    board.cluster_points = n;
    board.first_point = static_cast<int>(out->points.size());
    const int m = std::min(n, c.max_board_points);
    for (int k = 0; k < m; ++k) {
      const int i = static_cast<int>((static_cast<long long>(k) * n) / m);
      const RangeImageCell& cell = d.image.cell(members[seg.begin + i]);
      out->points.emplace_back(cell.x, cell.y, cell.z);
      out->point_indices.push_back(cell.index);
    }
    board.num_points = m;
    out->boards.push_back(board);
  }
  const Clock::time_point t4 = Clock::now();
  out->times.range_image_ms = Ms(t0, t1);
  out->times.ground_ms = Ms(t1, t2);
  out->times.segmentation_ms = Ms(t2, t3);
  out->times.descriptor_ms = Ms(t3, t4);
  out->times.total_ms = Ms(t0, t4);
}

}  // namespace calibd
