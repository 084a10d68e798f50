#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/common/parallel_for.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/validation.hpp"

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/lidar/board_references.hpp"
#include "calibd/core/lidar/cluster_pca.hpp"
#include "calibd/core/lidar/m2dp.hpp"
#include "calibd/core/lidar/plane_regions.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/lidar/segmentation.hpp"

namespace calibd {

namespace {

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

double Fraction(double v) { return v - std::floor(v); }

// A cluster refused as a whole is searched for a board-sized plane inside it, unless it was
// refused for capacity (nothing more can be kept).
bool ExtractsPlanes(ClusterGate gate) {
  return gate != ClusterGate::kBoard && gate != ClusterGate::kCapacity;
}

}  // namespace

bool LidarDetectorConfig::IsValid(std::string* error) const {
  if (!(segmentation_angle_deg > 0.0 && segmentation_angle_deg < 90.0))
    return Invalid(error, "segmentation_angle_deg: must be in (0, 90)");
  if (!(ground_angle_deg >= 0.0 && ground_angle_deg < 90.0))
    return Invalid(error, "ground_angle_deg: must be in [0, 90)");
  if (!FiniteAtLeast(ground_max_step_m, 0.0))
    return Invalid(error, "ground_max_step_m: must be >= 0");
  if (!FiniteAtLeast(cell_range_tolerance_m, 0.0))
    return Invalid(error, "cell_range_tolerance_m: must be >= 0");
  if (!FiniteAtLeast(min_range_m, 0.0)) return Invalid(error, "min_range_m: must be >= 0");
  if (!(max_range_m > min_range_m)) return Invalid(error, "max_range_m: must exceed min_range_m");
  if (neighbor_search_cells < 0 || neighbor_search_cells > 16)
    return Invalid(error, "neighbor_search_cells: must be in 0..16");
  if (!(min_row_width_fraction >= 0.0 && min_row_width_fraction < 1.0))
    return Invalid(error, "min_row_width_fraction: must be in [0, 1)");
  if (!(plane_distance_sigmas > 0.0 && plane_distance_sigmas <= 10.0))
    return Invalid(error, "plane_distance_sigmas: must be in (0, 10]");
  if (!(max_attached_fraction >= 0.0 && max_attached_fraction <= 1.0))
    return Invalid(error, "max_attached_fraction: must be in [0, 1]");
  if (!(max_trimmed_fraction >= 0.0 && max_trimmed_fraction <= 0.5))
    return Invalid(error, "max_trimmed_fraction: must be in [0, 0.5]");
  if (min_cluster_points < 3) return Invalid(error, "min_cluster_points: must be >= 3");
  if (!FiniteAtLeast(min_board_clearance_m, 0.0))
    return Invalid(error, "min_board_clearance_m: must be >= 0");
  if (!(extent_tolerance >= 0.0 && extent_tolerance < 1.0))
    return Invalid(error, "extent_tolerance: must be in [0, 1)");
  if (!FiniteAtLeast(max_side_tolerance, 0.0))
    return Invalid(error, "max_side_tolerance: must be >= 0");
  if (!(size_tolerance >= 0.0 && size_tolerance < 1.0))
    return Invalid(error, "size_tolerance: must be in [0, 1)");
  if (!FiniteAbove(max_planarity, 0.0)) return Invalid(error, "max_planarity: must be > 0");
  if (!(max_board_tilt_deg > 0.0 && max_board_tilt_deg <= 90.0))
    return Invalid(error, "max_board_tilt_deg: must be in (0, 90]");
  if (m2dp_elevations < 1 || m2dp_elevations > 64)
    return Invalid(error, "m2dp_elevations: must be in 1..64");
  if (m2dp_azimuths < 1 || m2dp_azimuths > 64)
    return Invalid(error, "m2dp_azimuths: must be in 1..64");
  if (m2dp_rings < 1 || m2dp_rings > 64) return Invalid(error, "m2dp_rings: must be in 1..64");
  if (m2dp_sectors < 1 || m2dp_sectors > 64)
    return Invalid(error, "m2dp_sectors: must be in 1..64");
  if (max_descriptor_points < min_cluster_points)
    return Invalid(error, "max_descriptor_points: must be >= min_cluster_points");
  if (!(reference_range_noise_m >= 0.0 && reference_range_noise_m < 1.0))
    return Invalid(error, "reference_range_noise_m: must be in [0, 1)");
  if (reference_samples < 1 || reference_samples > 256)
    return Invalid(error, "reference_samples: must be in 1..256");
  if (!(match_threshold >= 0.0 && match_threshold <= 1.0))
    return Invalid(error, "match_threshold: must be in [0, 1]");
  if (max_clusters < 1) return Invalid(error, "max_clusters: must be >= 1");
  if (max_boards < 1) return Invalid(error, "max_boards: must be >= 1");
  if (max_board_points < 1) return Invalid(error, "max_board_points: must be >= 1");
  if (max_points < 0) return Invalid(error, "max_points: must be >= 0 (0: from the LiDAR model)");
  return true;
}

// The standardized M2DP descriptor of a cluster, with its scratch sized once: one per thread.
struct Describer {
  M2dp m2dp;
  std::vector<Eigen::Vector3f> aligned;
  std::vector<float> aligned_weights;
  Eigen::VectorXf descriptor;

  Describer(const M2dpConfig& config, int max_points)
      : m2dp(config), aligned(max_points), aligned_weights(max_points), descriptor(m2dp.size()) {}

  // Standardized descriptor of `n` LiDAR-frame points into `descriptor`; false if degenerate.
  // `weights` (nullptr: all 1) as in ComputeClusterPca. Large clusters are evenly subsampled to
  // the scratch size (the bin counts need the shape, not every point).
  bool Describe(const Eigen::Vector3f* points, int n, const ClusterPca& pca,
                const float* weights = nullptr) {
    const int m = std::min(n, static_cast<int>(aligned.size()));
    for (int k = 0; k < m; ++k) {
      const int i = static_cast<int>((static_cast<long long>(k) * n) / m);
      aligned[k] = pca.axes.transpose().cast<float>() * (points[i] - pca.centroid.cast<float>());
      aligned_weights[k] = weights ? weights[i] : 1.0f;
    }
    if (!m2dp.Compute(aligned.data(), m, descriptor.data(), aligned_weights.data())) return false;
    return Standardize(descriptor.data(), m2dp.size());
  }
};

struct LidarDetector::Impl {
  LidarDetectorConfig config;
  LidarModel model;
  std::vector<BoardGeometry> boards;
  bool ok = false;
  std::string error;

  RangeImage image;
  RangeSegmenter segmenter;
  Describer describer;
  // The references' build tasks: every distinct board size seen from each
  // DefaultReferenceViews().
  struct ReferenceTask {
    double width_m, height_m;
    BoardView view;
  };
  std::vector<ReferenceTask> tasks;  // the references' build tasks (ReferenceTasks)
  // The standardized reference descriptors (built, or taken from a cache), with their key.
  LidarReferenceSet reference_set;
  bool references_from_cache = false;
  std::string cache_refusal;
  double min_side_m = 0.0;
  // Largest area of a board passing the rectangle gate (its long side squared, m^2) and the
  // solid angle of the smallest range-image cell (sr), for the fast pre-check in Detect().
  double max_board_area_m2 = 0.0;
  double min_cell_sr = 0.0;

  // Per-cluster scratch, sized once: one point per cell of a cluster (the mean of the cell's
  // points) and the input indices of all its points.
  std::vector<Eigen::Vector3f> cluster_points;
  std::vector<int32_t> cluster_indices;
  // Planes inside clusters that fail as a whole, and the scratch of one plane.
  PlaneRegions planes;
  std::vector<Eigen::Vector3f> region_points;
  std::vector<int32_t> region_cells;
  std::vector<float> cluster_weights;
  // A cluster cut to its board-sized window (TrimToBoard) and the window search's scratch.
  std::vector<Eigen::Vector3f> trim_points;
  std::vector<int32_t> trim_cells;
  std::vector<std::pair<float, float>> window_scratch;
  std::vector<double> row_gap_sum;  // per range-image row, for RowWeights()
  std::vector<int> row_cells;
  Eigen::VectorXf scores;

  // The describer's scratch is sized for one point here and replaced by one sized for
  // max_descriptor_points once the config is checked (LidarDetector's constructor).
  Impl(const LidarDetectorConfig& c, const LidarModel& m)
      : config(c), model(m), describer(M2dpOf(c), 1) {}

  static M2dpConfig M2dpOf(const LidarDetectorConfig& c) {
    M2dpConfig m;
    m.elevations = c.m2dp_elevations;
    m.azimuths = c.m2dp_azimuths;
    m.rings = c.m2dp_rings;
    m.sectors = c.m2dp_sectors;
    return m;
  }

  // True when at least half of the cluster's lower-edge cells have ground right below them in
  // the image within min_board_clearance_m of their height: a box standing on the floor (whose
  // bottom strip the ground walk may even have taken), not a board on a stand, whose lower edge
  // has the floor far behind it or its post below.
  // `cells` and `points` (n of them) are the cluster's; a cell belongs to it when mark[cell] == id.
  bool RestsOnGround(const int32_t* cells, const Eigen::Vector3f* points, int n,
                     const int32_t* mark, int32_t id) const {
    static constexpr int kSearchRows = 3;
    const std::vector<int32_t>& labels = segmenter.labels();
    const float clearance = static_cast<float>(config.min_board_clearance_m);
    int edge = 0, contact = 0;
    for (int k = 0; k < n; ++k) {
      const int row = image.RowOf(cells[k]), col = image.ColOf(cells[k]);
      int below = -1;
      for (int r = row - 1; r >= std::max(0, row - kSearchRows); --r) {
        if (image.cell(r, col).index >= 0) {
          below = image.CellIndex(r, col);
          break;
        }
      }
      if (below >= 0 && mark[below] == id) continue;  // inside the cluster
      ++edge;
      if (below >= 0 && labels[below] == kLabelGround &&
          points[k].z() - image.cell(below).z < clearance)
        ++contact;
    }
    return 2 * contact >= edge && contact > 0;
  }

  // Elevation gap (rad) that the sample of cell `index` stands for: half the gaps to the nearest
  // non-empty cells below and above it in its column (searched kGapSearchRows far; a side without
  // one takes the other side's gap, neither the row spacing).
  double VerticalGap(int index) const {
    static constexpr int kGapSearchRows = 8;
    const int row = image.RowOf(index), col = image.ColOf(index);
    const double el = image.row_elevation_rad(row);
    double gap[2] = {-1.0, -1.0};  // below, above
    for (int side = 0; side < 2; ++side) {
      const int dr = side == 0 ? -1 : 1;
      for (int step = 1; step <= kGapSearchRows; ++step) {
        const int r = row + dr * step;
        if (r < 0 || r >= image.rows()) break;
        if (image.cell(r, col).index >= 0) {
          gap[side] = std::fabs(image.row_elevation_rad(r) - el);
          break;
        }
      }
    }
    if (gap[0] > 0.0 && gap[1] > 0.0) return 0.5 * (gap[0] + gap[1]);
    if (gap[0] > 0.0 || gap[1] > 0.0) return std::max(gap[0], gap[1]);
    return image.row_spacing_rad(row);
  }

  // Weight of each of the cluster's n cells (weight_by_sample_area): the mean VerticalGap of the
  // cluster's cells in its row. The Falcon's 0.075 deg lines within 3 deg of the horizon and 0.2
  // deg lines outside split a board crossing that edge into halves of 2.7 times different
  // density, which pulls its centroid 7 cm and drops its score from 0.99 to 0.93 (measured); the
  // weights make both halves count alike. Averaged over the row because an M1's slanted lines
  // leave cell gaps of 1 and 2 rows at random, which per cell only add noise (its recall at 0.94
  // drops from 0.94 to 0.89 per cell, 0.94 per row: measured).
  void RowWeights(const int32_t* cells, int n) {
    for (int k = 0; k < n; ++k) {
      const int row = image.RowOf(cells[k]);
      row_gap_sum[row] = 0.0;
      row_cells[row] = 0;
    }
    for (int k = 0; k < n; ++k) {
      const int row = image.RowOf(cells[k]);
      row_gap_sum[row] += VerticalGap(cells[k]);
      ++row_cells[row];
    }
    for (int k = 0; k < n; ++k) {
      const int row = image.RowOf(cells[k]);
      cluster_weights[k] = static_cast<float>(row_gap_sum[row] / row_cells[row]);
    }
  }

  int num_references() const { return static_cast<int>(reference_set.views.size()); }

  double BestScore() {
    if (num_references() == 0) return 0.0;
    const Eigen::Map<const Eigen::MatrixXf> references(reference_set.descriptors.data(),
                                                       reference_set.dims, num_references());
    scores.noalias() = references.transpose() * describer.descriptor;
    // Negative correlations are neglected (paper §III-C-2).
    return std::max(0.0, static_cast<double>(scores.maxCoeff()));
  }

  // The cheap gates before the descriptor. Fills `figures`' planarity, tilt and RMS size, and its
  // in-plane rectangle once the planarity and tilt gates pass (zero before), or always with
  // `all_figures`.
  ClusterGate Gates(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                    double beam_spacing_rad, bool all_figures, LidarClusterReport* figures) const {
    figures->planarity = pca.planarity();
    // Upright: the normal's angle above the horizontal plane.
    figures->tilt_deg = std::asin(std::min(1.0, std::fabs(pca.axes(2, 2)))) / kDeg2Rad;
    figures->size_m = std::sqrt(std::max(0.0, pca.eigenvalues(0) + pca.eigenvalues(1)));
    figures->rectangle =
        all_figures ? InPlaneRectangle(pca, points, n) : Eigen::Vector2d(Eigen::Vector2d::Zero());
    if (figures->planarity > config.max_planarity) return ClusterGate::kNotPlanar;
    if (figures->tilt_deg > config.max_board_tilt_deg) return ClusterGate::kTilted;
    const double spacing = pca.centroid.norm() * beam_spacing_rad;
    const double size = figures->size_m;
    const double size_tol = config.size_tolerance;
    if (!all_figures) figures->rectangle = InPlaneRectangle(pca, points, n);
    const Eigen::Vector2d& rectangle = figures->rectangle;
    ClusterGate gate = ClusterGate::kRectangle;
    for (const BoardGeometry& g : boards) {
      const double lo = (1.0 - config.extent_tolerance) * std::min(g.width_m, g.height_m) - spacing;
      const double hi =
          (1.0 + config.max_side_tolerance) * std::max(g.width_m, g.height_m) + 0.5 * spacing;
      if (rectangle(0) > hi || rectangle(1) < lo) continue;
      gate = ClusterGate::kSize;
      // RMS size of a uniformly sampled w x h rectangle: sqrt((w^2 + h^2) / 12).
      const double full = std::sqrt((g.width_m * g.width_m + g.height_m * g.height_m) / 12.0);
      if (size >= (1.0 - size_tol) * full - 0.5 * spacing && size <= (1.0 + size_tol) * full)
        return ClusterGate::kBoard;
    }
    return gate;
  }

  // Fast pre-check: a board whose sides pass the rectangle gate covers at most
  // max_board_area_m2 / r^2 steradians at range r, so at most that many cells of the finest grid
  // step (twice that, for safety): walls and large objects stop here before the per-cell work.
  bool TooLarge(const int32_t* cells, int n) const {
    double min_range = 1e300;
    for (int k = 0; k < n; ++k) min_range = std::min(min_range, double{image.cell(cells[k]).range});
    return n > 2.0 * max_board_area_m2 / (min_range * min_range * min_cell_sr);
  }

  // With report_clusters, where a cluster stopped and its figures.
  void Report(ClusterGate gate, LidarClusterReport* report, LidarDetections* out) const {
    if (!config.report_clusters || static_cast<int>(out->clusters.size()) >= config.max_clusters)
      return;
    report->gate = gate;
    out->clusters.push_back(*report);
  }

  // One point per cell of a segment, the mean of the cell's points (paper §III-C-1: the average of
  // a pixel once far points are removed), into cluster_points: the cluster is sampled on the
  // range-image grid like the references, whatever the scan pattern's density. An M1 board at 7 m
  // near a zone edge has three times the points on one side (the sinusoidal sweep turns there): it
  // scores 0.86 with all points, 0.97 with one per cell (measured with M2DP l = 4, t = 16). All the
  // cells' points go to the output.
  void FillPoints(const PointCloudView& cloud, const int32_t* cells, int n) {
    const int32_t* next_point = image.next_point().data();
    for (int k = 0; k < n; ++k) {
      const RangeImageCell& cell = image.cell(cells[k]);
      Eigen::Vector3f sum(cell.x, cell.y, cell.z);
      for (int32_t i = cell.next_point; i >= 0; i = next_point[i])
        sum += Eigen::Vector3f(cloud.x[i], cloud.y[i], cloud.z[i]);
      cluster_points[k] = sum / static_cast<float>(cell.num_points);
    }
  }

  // The cells of a cluster (n `cells` with their `points`) inside the board-sized window that
  // holds most of them, into trim_cells and trim_points: their count, or 0 when more than
  // max_trimmed_fraction of the cells lie outside every board's window. The window is the board's
  // own size, without the rectangle gate's allowance for the beam footprint: a strip running
  // along the board would fill that allowance, while the board's own points beyond its edges are
  // few (and leaving some out biases nothing: the box cost of Eq. 4 asks points to be inside).
  int TrimToBoard(const ClusterPca& pca, const int32_t* cells, const Eigen::Vector3f* points,
                  int n) {
    PlaneWindow best;
    for (const BoardGeometry& g : boards) {
      const PlaneWindow w =
          MostPointsWindow(pca, points, n, g.width_m, g.height_m, window_scratch.data());
      if (w.count > best.count) best = w;
    }
    if (best.count == n || n - best.count > config.max_trimmed_fraction * n) return 0;
    int m = 0;
    for (int k = 0; k < n; ++k) {
      if (!best.Contains(pca, points[k])) continue;
      trim_cells[m] = cells[k];
      trim_points[m++] = points[k];
    }
    return m;
  }

  // Gates, descriptor and output of one cluster not too large to be a board: n range-image cells
  // `cells` with their points (FillPoints), the cells c with mark[c] == id (the segmenter's
  // labels, or a plane's). With `may_trim`, a cluster too long for a board is cut to its
  // board-sized window (TrimToBoard) and evaluated again.
  ClusterGate Evaluate(const PointCloudView& cloud, const int32_t* cells,
                       const Eigen::Vector3f* points, int n, const int32_t* mark, int32_t id,
                       LidarClusterReport* report, LidarDetections* out, bool may_trim = true) {
    const LidarDetectorConfig& c = config;
    const int32_t* next_point = image.next_point().data();
    double spacing_sum = 0.0;
    for (int k = 0; k < n; ++k) spacing_sum += image.row_spacing_rad(image.RowOf(cells[k]));
    const double beam_spacing = std::max(image.azimuth_step_rad(), spacing_sum / n);
    const bool on_ground =
        c.min_board_clearance_m > 0.0 && RestsOnGround(cells, points, n, mark, id);
    if (on_ground && !c.report_clusters) return ClusterGate::kOnGround;
    if (c.weight_by_sample_area) RowWeights(cells, n);
    const float* weights = c.weight_by_sample_area ? cluster_weights.data() : nullptr;
    ClusterPca pca;
    ComputeClusterPca(points, n, &pca, weights);
    report->centroid = pca.centroid;
    ClusterGate gate = Gates(pca, points, n, beam_spacing, c.report_clusters, report);
    if (on_ground) gate = ClusterGate::kOnGround;
    if (gate == ClusterGate::kRectangle && may_trim && c.extract_planes &&
        c.max_trimmed_fraction > 0.0) {
      const int m = TrimToBoard(pca, cells, points, n);
      if (m > 0) {
        report->trimmed_cells = n - m;
        // Once: the nested call does not trim, so trim_* stay as they are.
        return Evaluate(cloud, trim_cells.data(), trim_points.data(), m, mark, id, report, out,
                        false);
      }
    }
    if (gate != ClusterGate::kBoard) {
      Report(gate, report, out);
      return gate;
    }
    if (static_cast<int>(out->candidates.size()) >= c.max_clusters) {
      ++out->dropped_candidates;
      Report(ClusterGate::kCapacity, report, out);
      return ClusterGate::kCapacity;
    }
    const double score = describer.Describe(points, n, pca, weights) ? BestScore() : 0.0;
    report->score = score;
    LidarCandidate cand;
    cand.centroid = pca.centroid;
    cand.score = score;
    cand.num_points = n;
    cand.extents = pca.extents;
    cand.planarity = pca.planarity();
    cand.eigenvalues = pca.eigenvalues;
    cand.rectangle = report->rectangle;
    out->candidates.push_back(cand);
    if (score < c.match_threshold) {
      Report(ClusterGate::kDescriptor, report, out);
      return ClusterGate::kDescriptor;
    }
    if (static_cast<int>(out->boards.size()) >= c.max_boards) {
      ++out->dropped_boards;
      Report(ClusterGate::kCapacity, report, out);
      return ClusterGate::kCapacity;
    }
    Report(ClusterGate::kBoard, report, out);
    BoardCluster board;
    board.centroid = pca.centroid;
    board.normal = pca.axes.col(2);
    if (board.normal.dot(pca.centroid) > 0.0) board.normal = -board.normal;  // towards the sensor
    board.score = score;
    int num_indices = 0;
    for (int k = 0; k < n; ++k) {
      const RangeImageCell& cell = image.cell(cells[k]);
      cluster_indices[num_indices++] = cell.index;
      for (int32_t i = cell.next_point; i >= 0; i = next_point[i])
        cluster_indices[num_indices++] = i;
    }
    board.cluster_points = num_indices;
    board.first_point = static_cast<int>(out->points.size());
    const int m = std::min(num_indices, c.max_board_points);
    for (int k = 0; k < m; ++k) {
      const int32_t i = cluster_indices[(static_cast<long long>(k) * num_indices) / m];
      out->points.emplace_back(cloud.x[i], cloud.y[i], cloud.z[i]);
      out->point_indices.push_back(i);
      out->point_time_s.push_back(
          cloud.time_offset_us ? static_cast<float>(cloud.time_offset_us[i]) * 1e-6f : 0.0f);
    }
    board.num_points = m;
    out->boards.push_back(board);
    return ClusterGate::kBoard;
  }

  // One reference: the standardized mean of the descriptors of `view` of a width x height board
  // at config.reference_samples phases of the beam grid; empty when no sample is usable.
  void DescribeView(double width_m, double height_m, const BoardView& view, uint64_t view_index,
                    Describer* scratch, std::vector<float>* reference) const {
    std::vector<Eigen::Vector3f> pts;
    std::vector<float> weights;
    Eigen::VectorXf sum = Eigen::VectorXf::Zero(scratch->m2dp.size());
    int used = 0;
    for (int k = 0; k < config.reference_samples; ++k) {
      // Grid phases from the R2 low-discrepancy sequence (Roberts 2018): k = 0 is phase 0, the
      // next ones spread evenly over the unit square.
      BoardView v = view;
      v.azimuth_phase = Fraction(0.5 + k * 0.7548776662466927) - 0.5;
      v.elevation_phase = Fraction(0.5 + k * 0.5698402909980532) - 0.5;
      SimulateBoardCluster(model, width_m, height_m, v, &pts, &weights);
      AddRangeNoise(config.reference_range_noise_m, view_index * 1000003ULL + k, &pts);
      const int n = static_cast<int>(pts.size());
      if (n < config.min_cluster_points) continue;
      const float* w = config.weight_by_sample_area ? weights.data() : nullptr;
      ClusterPca pca;
      ComputeClusterPca(pts.data(), n, &pca, w);
      if (!scratch->Describe(pts.data(), n, pca, w)) continue;
      sum += scratch->descriptor;
      ++used;
    }
    reference->clear();
    if (used > 0 && Standardize(sum.data(), static_cast<int>(sum.size())))
      reference->assign(sum.data(), sum.data() + sum.size());
  }

  static std::vector<ReferenceTask> ReferenceTasks(const std::vector<BoardGeometry>& boards) {
    std::vector<ReferenceTask> tasks;
    std::vector<std::pair<double, double>> sizes;
    for (const BoardGeometry& g : boards) {
      const std::pair<double, double> s(g.width_m, g.height_m);
      if (std::find(sizes.begin(), sizes.end(), s) != sizes.end()) continue;
      sizes.push_back(s);
      for (const BoardView& view : DefaultReferenceViews())
        tasks.push_back({s.first, s.second, view});
    }
    return tasks;
  }

  // The reference of build task `t` (its noise seed is t + 1, whichever thread builds it).
  void DescribeTask(size_t t, Describer* scratch, std::vector<float>* reference) const {
    DescribeView(tasks[t].width_m, tasks[t].height_m, tasks[t].view, t + 1, scratch, reference);
  }

  // The reference descriptors of every distinct board size (paper §III-C-2), built on two
  // threads (views x reference_samples descriptors per board size). Each view has its own noise
  // seed, so the result does not depend on the thread count. False when `cancel` stopped it.
  bool BuildReferences(const std::atomic<bool>* cancel) {
    std::vector<std::vector<float>> descs(tasks.size());
    auto cancelled = [cancel] { return cancel != nullptr && cancel->load(); };
    Describer second(M2dpOf(config), static_cast<int>(describer.aligned.size()));
    Describer* scratch[] = {&describer, &second};
    ParallelFor(2, static_cast<int>(tasks.size()), [&](int worker, int task) {
      if (!cancelled()) DescribeTask(static_cast<size_t>(task), scratch[worker], &descs[task]);
    });
    if (cancelled()) return false;
    LidarReferenceSet built;
    built.dims = describer.m2dp.size();
    for (size_t t = 0; t < descs.size(); ++t) {
      if (descs[t].empty()) continue;
      built.views.push_back(static_cast<int32_t>(t));
      built.descriptors.insert(built.descriptors.end(), descs[t].begin(), descs[t].end());
    }
    TakeReferences(std::move(built));
    return true;
  }

  // Descriptors of the cached set built again for this many tasks, spread over all of them.
  static constexpr int kSpotChecks = 8;
  // A descriptor built again may differ from the cached one by this much (standardized values
  // of about 0.1; the same build gives the same bits, another compiler the last few).
  static constexpr float kSpotCheckTolerance = 1e-4f;

  // Takes `cached` when it fits this detector (see the constructor); else false with `refusal`.
  bool TakeCached(const LidarReferenceSet& cached, uint64_t key, std::string* refusal) {
    const int dims = describer.m2dp.size();
    if (cached.key != key) {
      *refusal = "built for another config, LiDAR model or board sizes";
      return false;
    }
    const size_t n = cached.views.size();
    bool shaped = cached.dims == dims && n > 0 &&
                  cached.descriptors.size() == n * static_cast<size_t>(dims) &&
                  cached.views.back() < static_cast<int32_t>(tasks.size()) &&
                  cached.views.front() >= 0;
    for (size_t i = 1; shaped && i < n; ++i) shaped = cached.views[i] > cached.views[i - 1];
    for (size_t i = 0; shaped && i < cached.descriptors.size(); ++i)
      shaped = std::isfinite(cached.descriptors[i]);
    if (!shaped) {
      *refusal =
          "malformed: not " + std::to_string(dims) + " finite values for each of increasing views";
      return false;
    }
    std::vector<float> again;
    for (int k = 0; k < kSpotChecks; ++k) {
      const size_t t = (tasks.size() - 1) * static_cast<size_t>(k) / (kSpotChecks - 1);
      DescribeTask(t, &describer, &again);
      const auto at =
          std::lower_bound(cached.views.begin(), cached.views.end(), static_cast<int32_t>(t));
      const bool listed = at != cached.views.end() && *at == static_cast<int32_t>(t);
      bool same = listed != again.empty();
      if (same && listed) {
        const float* old =
            cached.descriptors.data() + static_cast<size_t>(at - cached.views.begin()) * dims;
        for (int i = 0; i < dims && same; ++i)
          same = std::fabs(old[i] - again[static_cast<size_t>(i)]) <= kSpotCheckTolerance;
      }
      if (!same) {
        *refusal = "reference view " + std::to_string(t) +
                   " built again differs from the cached one (another build of calibd)";
        return false;
      }
    }
    TakeReferences(cached);
    return true;
  }

  // `set` becomes the detector's references (the caller has set reference_set.key).
  void TakeReferences(LidarReferenceSet set) {
    set.key = reference_set.key;
    reference_set = std::move(set);
    scores.resize(num_references());
  }

  // One segment of the range image: evaluated as a board candidate, and where it is not a board
  // as a whole (and plane extraction is on), its planes (EvaluatePlanes).
  void EvaluateSegment(const PointCloudView& cloud, int s, LidarDetections* out) {
    const LidarDetectorConfig& c = config;
    const Segment& seg = segmenter.segment(s);
    const int n = seg.size();
    if (n < c.min_cluster_points) return;
    const int32_t* cells = segmenter.members() + seg.begin;
    LidarClusterReport report;
    report.segment = s;
    report.num_points = n;
    report.first_cell = cells[0];
    const bool too_large = TooLarge(cells, n);
    if (too_large && !c.extract_planes) {
      if (c.report_clusters) {
        const RangeImageCell& first = image.cell(cells[0]);
        report.centroid = Eigen::Vector3d(first.x, first.y, first.z);
      }
      Report(ClusterGate::kTooLarge, &report, out);
      return;
    }
    FillPoints(cloud, cells, n);
    ClusterGate gate = ClusterGate::kTooLarge;
    if (too_large) {
      report.centroid = cluster_points[0].cast<double>();
      Report(gate, &report, out);
    } else {
      gate = Evaluate(cloud, cells, cluster_points.data(), n, segmenter.labels().data(), seg.label,
                      &report, out);
    }
    if (c.extract_planes && ExtractsPlanes(gate)) EvaluatePlanes(cloud, s, cells, n, out);
  }

  // The cluster is not a board as a whole: the board may be one of its planes
  // (plane_regions.hpp). Each plane is evaluated like a cluster of its own.
  void EvaluatePlanes(const PointCloudView& cloud, int s, const int32_t* cells, int n,
                      LidarDetections* out) {
    const int num_planes = planes.Extract(image, cells, cluster_points.data(), n);
    for (int p = 0; p < num_planes; ++p) {
      const PlaneRegion& region = planes.region(p);
      if (region.size() == n) break;  // the whole cluster again
      for (int m = 0; m < region.size(); ++m) {
        const int32_t k = planes.members()[region.begin + m];
        region_cells[m] = cells[k];
        region_points[m] = cluster_points[k];
      }
      LidarClusterReport plane_report;
      plane_report.segment = s;
      plane_report.plane = p;
      plane_report.num_points = region.size();
      plane_report.first_cell = region_cells[0];
      plane_report.centroid = region.center.cast<double>();
      if (TooLarge(region_cells.data(), region.size())) {
        Report(ClusterGate::kTooLarge, &plane_report, out);
        continue;
      }
      plane_report.attached_fraction = planes.AttachedFraction(image, cluster_points.data(), p);
      if (plane_report.attached_fraction > config.max_attached_fraction) {
        Report(ClusterGate::kAttached, &plane_report, out);
        continue;
      }
      Evaluate(cloud, region_cells.data(), region_points.data(), region.size(),
               planes.cell_region().data(), p + 1, &plane_report, out);
    }
  }
};

bool LidarDetector::CheckInputs(const LidarDetectorConfig& config, const LidarModel& model,
                                const std::vector<BoardGeometry>& boards, std::string* error) {
  if (!config.IsValid(error)) return false;
  if (boards.empty()) return Invalid(error, "boards: at least one board is needed");
  for (const BoardGeometry& g : boards) {
    std::string e;
    if (!g.IsValid(&e)) return Invalid(error, "boards: " + e);
  }
  if (!(model.azimuth_resolution_deg > 0.0) ||
      (!model.has_rings && !(model.elevation_resolution_deg > 0.0)) ||
      !(model.azimuth_max_deg > model.azimuth_min_deg) ||
      (model.has_rings && model.ring_elevation_deg.empty()))
    return Invalid(
        error, "lidar model: needs positive resolutions, a field of view and, with rings, a table");
  return true;
}

LidarDetector::LidarDetector(const LidarDetectorConfig& config, const LidarModel& model,
                             const std::vector<BoardGeometry>& boards,
                             const std::atomic<bool>* cancel, const LidarReferenceSet* cached)
    : impl_(std::make_unique<Impl>(config, model)) {
  Impl& d = *impl_;
  if (!CheckInputs(config, model, boards, &d.error)) return;
  d.boards = boards;
  d.min_side_m = 1e300;
  for (const BoardGeometry& g : boards)
    d.min_side_m = std::min({d.min_side_m, g.width_m, g.height_m});
  const size_t max_points =
      config.max_points > 0
          ? static_cast<size_t>(config.max_points)
          : 2 * static_cast<size_t>(std::max(model.nominal_points_per_frame, 100000));
  d.image.Configure(model, config.min_range_m, config.max_range_m, max_points,
                    config.cell_range_tolerance_m);
  SegmentationConfig sc;
  sc.ground_angle_deg = config.ground_angle_deg;
  sc.ground_max_step_m = config.ground_max_step_m;
  sc.segmentation_angle_deg = config.segmentation_angle_deg;
  sc.neighbor_search_cells = config.neighbor_search_cells;
  sc.min_cluster_points = config.min_cluster_points;
  sc.min_row_width_m = config.min_row_width_fraction * d.min_side_m;
  d.segmenter.Configure(d.image, sc);
  PlaneRegionConfig pc;
  pc.distance_sigmas = config.plane_distance_sigmas;
  pc.neighbor_search_cells = config.neighbor_search_cells;
  pc.min_region_cells = config.min_cluster_points;
  pc.window_half_m = 0.25 * d.min_side_m;
  pc.min_board_area_m2 = d.min_side_m * d.min_side_m;
  pc.min_row_width_m = sc.min_row_width_m;
  d.planes.Configure(d.image, pc);
  for (const BoardGeometry& g : boards) {
    const double side = (1.0 + config.max_side_tolerance) * std::max(g.width_m, g.height_m);
    d.max_board_area_m2 = std::max(d.max_board_area_m2, side * side);
  }
  double min_gap = 1e300;
  for (int row = 0; row + 1 < d.image.rows(); ++row)
    min_gap =
        std::min(min_gap, d.image.row_elevation_rad(row + 1) - d.image.row_elevation_rad(row));
  if (d.image.rows() < 2) min_gap = d.image.row_spacing_rad(0);
  d.min_cell_sr = d.image.azimuth_step_rad() * std::max(min_gap, 1e-6);
  d.cluster_points.resize(static_cast<size_t>(d.image.rows()) * d.image.cols());
  d.region_points.resize(d.cluster_points.size());
  d.region_cells.resize(d.cluster_points.size());
  d.row_gap_sum.resize(d.image.rows());
  d.row_cells.resize(d.image.rows());
  // Every input point is a cell's nearest or in one chain: a cluster has at most max_points.
  d.cluster_indices.resize(max_points);
  d.cluster_weights.resize(d.cluster_points.size());
  d.trim_points.resize(d.cluster_points.size());
  d.trim_cells.resize(d.cluster_points.size());
  d.window_scratch.resize(d.cluster_points.size());
  d.describer = Describer(Impl::M2dpOf(config), config.max_descriptor_points);
  d.tasks = Impl::ReferenceTasks(boards);
  d.reference_set.key = ReferenceKey(config, model, boards);
  if (cached != nullptr)
    d.references_from_cache = d.TakeCached(*cached, d.reference_set.key, &d.cache_refusal);
  if (!d.references_from_cache && !d.BuildReferences(cancel)) {
    d.error = "cancelled while its reference descriptors were built";
    return;
  }
  if (d.num_references() == 0) {
    d.error = "boards: no reference cluster has min_cluster_points points for this LiDAR model";
    return;
  }
  d.ok = true;
}

LidarDetector::~LidarDetector() = default;

bool LidarDetector::ok() const { return impl_->ok; }
const std::string& LidarDetector::error() const { return impl_->error; }
int LidarDetector::num_references() const { return impl_->num_references(); }
bool LidarDetector::references_from_cache() const { return impl_->references_from_cache; }
const std::string& LidarDetector::cache_refusal() const { return impl_->cache_refusal; }

LidarReferenceSet LidarDetector::references() const {
  return impl_->ok ? impl_->reference_set : LidarReferenceSet{};
}

uint64_t LidarDetector::ReferenceKey(const LidarDetectorConfig& config, const LidarModel& model,
                                     const std::vector<BoardGeometry>& boards) {
  Fingerprint f;
  f.Add("calibd LidarReferenceSet 1");  // the layout of the set and what follows
  const LidarDetectorConfig& c = config;
  for (int v : {c.m2dp_elevations, c.m2dp_azimuths, c.m2dp_rings, c.m2dp_sectors,
                c.max_descriptor_points, c.reference_samples, c.min_cluster_points})
    f.AddValue(v);
  f.AddValue(c.reference_range_noise_m);
  f.AddValue(c.weight_by_sample_area);
  f.AddValue(static_cast<int>(model.kind));
  f.Add(model.name);
  f.AddValue(model.has_rings);
  f.AddValue(model.ring_elevation_deg.size());
  for (double e : model.ring_elevation_deg) f.AddValue(e);
  for (double v :
       {model.azimuth_resolution_deg, model.elevation_resolution_deg, model.azimuth_min_deg,
        model.azimuth_max_deg, model.elevation_min_deg, model.elevation_max_deg, model.min_range_m,
        model.max_range_m, model.range_quantization_m, model.frame_rate_hz})
    f.AddValue(v);
  for (int v : {model.nominal_points_per_frame, model.pattern_points_per_frame}) f.AddValue(v);
  f.AddValue(model.non_repetitive);
  for (const Impl::ReferenceTask& t : Impl::ReferenceTasks(boards))
    for (double v : {t.width_m, t.height_m, t.view.distance_m, t.view.elevation_deg, t.view.yaw_deg,
                     t.view.pitch_deg, t.view.azimuth_phase, t.view.elevation_phase})
      f.AddValue(v);
  return f.value();
}

const RangeImage& LidarDetector::range_image() const { return impl_->image; }

const std::vector<int32_t>& LidarDetector::cell_labels() const { return impl_->segmenter.labels(); }

int32_t LidarDetector::segment_label(int segment) const {
  return segment >= 0 && segment < impl_->segmenter.num_segments()
             ? impl_->segmenter.segment(segment).label
             : kLabelNone;
}

double LidarDetector::ScoreCluster(const std::vector<Eigen::Vector3f>& points) {
  Impl& d = *impl_;
  if (!d.ok || points.size() < 3) return 0.0;
  ClusterPca pca;
  ComputeClusterPca(points.data(), static_cast<int>(points.size()), &pca);
  if (!d.describer.Describe(points.data(), static_cast<int>(points.size()), pca)) return 0.0;
  return d.BestScore();
}

const char* ClusterGateName(ClusterGate gate) {
  switch (gate) {
    case ClusterGate::kBoard:
      return "board";
    case ClusterGate::kTooLarge:
      return "too_large";
    case ClusterGate::kAttached:
      return "attached";
    case ClusterGate::kOnGround:
      return "on_ground";
    case ClusterGate::kNotPlanar:
      return "not_planar";
    case ClusterGate::kTilted:
      return "tilted";
    case ClusterGate::kRectangle:
      return "rectangle";
    case ClusterGate::kSize:
      return "size";
    case ClusterGate::kDescriptor:
      return "descriptor";
    case ClusterGate::kCapacity:
      return "capacity";
  }
  return "board";
}

void LidarDetector::ReserveOutput(LidarDetections* out) const {
  const LidarDetectorConfig& c = impl_->config;
  const size_t point_capacity = static_cast<size_t>(c.max_boards) * c.max_board_points;
  if (out->boards.capacity() < static_cast<size_t>(c.max_boards)) out->boards.reserve(c.max_boards);
  if (out->points.capacity() < point_capacity) out->points.reserve(point_capacity);
  if (out->point_indices.capacity() < point_capacity) out->point_indices.reserve(point_capacity);
  if (out->point_time_s.capacity() < point_capacity) out->point_time_s.reserve(point_capacity);
  if (out->candidates.capacity() < static_cast<size_t>(c.max_clusters))
    out->candidates.reserve(c.max_clusters);
  if (c.report_clusters && out->clusters.capacity() < static_cast<size_t>(c.max_clusters))
    out->clusters.reserve(c.max_clusters);
}

namespace {

// Empties `out` for the detections of `cloud`, keeping its capacities.
void ClearOutput(const PointCloudView& cloud, LidarDetections* out) {
  out->boards.clear();
  out->points.clear();
  out->point_indices.clear();
  out->point_time_s.clear();
  out->candidates.clear();
  out->clusters.clear();
  out->cloud_points = static_cast<int>(cloud.size);
  out->invalid_points = out->outside_points = out->dropped_points = out->overflow_points = 0;
  out->chained_points = 0;
  out->num_clusters = out->dropped_candidates = out->dropped_boards = 0;
  out->times = LidarStageTimes{};
}

}  // namespace

void LidarDetector::Detect(const PointCloudView& cloud, LidarDetections* out) {
  Impl& d = *impl_;
  // Capacities are reserved on the first use of `out` (unless ReserveOutput did it); later calls
  // only clear and refill.
  ReserveOutput(out);
  ClearOutput(cloud, out);
  if (!d.ok) return;

  const SteadyClock::time_point t0 = SteadyClock::now();
  RangeImageStats stats;
  d.image.Build(cloud, &stats);
  out->invalid_points = stats.invalid_points;
  out->outside_points = stats.outside_points;
  out->dropped_points = stats.dropped_points;
  out->chained_points = stats.chained_points;
  out->overflow_points = stats.overflow_points;
  const SteadyClock::time_point t1 = SteadyClock::now();
  d.segmenter.LabelGround(d.image);
  const SteadyClock::time_point t2 = SteadyClock::now();
  d.segmenter.Cluster(d.image);
  out->num_clusters = d.segmenter.num_segments();
  const SteadyClock::time_point t3 = SteadyClock::now();

  for (int s = 0; s < d.segmenter.num_segments(); ++s) d.EvaluateSegment(cloud, s, out);
  const SteadyClock::time_point t4 = SteadyClock::now();
  out->times.range_image_ms = MsBetween(t0, t1);
  out->times.ground_ms = MsBetween(t1, t2);
  out->times.segmentation_ms = MsBetween(t2, t3);
  out->times.descriptor_ms = MsBetween(t3, t4);
  out->times.total_ms = MsBetween(t0, t4);
}

}  // namespace calibd
