#include "calibd/core/solve/grid_search.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <vector>

#include "calibd/core/common/parallel_for.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/validation.hpp"

namespace calibd {

namespace {

// FastAtan2 (about 1e-5 rad) is far below a range-image cell (>= 1.3e-3 rad) and several times
// cheaper than std::atan2: this runs 8 times per region and candidate.
bool CellOfPoint(const RangeImage& img, const Eigen::Vector3d& p, int* row, int* col) {
  const float horizontal = static_cast<float>(std::sqrt(p.x() * p.x() + p.y() * p.y()));
  return img.CellOf(FastAtan2(static_cast<float>(p.y()), static_cast<float>(p.x())),
                    FastAtan2(static_cast<float>(p.z()), horizontal), row, col);
}

}  // namespace

bool GridSearchConfig::IsValid(std::string* error) const {
  if (!(range_deg >= 0.0 && range_deg <= 30.0))
    return Invalid(error, "grid.range_deg must be in [0, 30]");
  if (!(step_deg > 0.0 && step_deg <= 10.0))
    return Invalid(error, "grid.step_deg must be in (0, 10]");
  if (range_deg / step_deg > 40.0) return Invalid(error, "grid.range_deg / step_deg must be <= 40");
  if (refine && !(refine_step_deg > 0.0 && refine_range_deg / refine_step_deg <= 40.0))
    return Invalid(error, "grid.refine_step_deg must be > 0 and refine_range/refine_step <= 40");
  if (min_points < 1) return Invalid(error, "grid.min_points must be >= 1");
  if (max_scoring_frames < 0) return Invalid(error, "grid.max_scoring_frames must be >= 0");
  if (!(min_point_fraction >= 0.0 && min_point_fraction <= 1.0))
    return Invalid(error, "grid.min_point_fraction must be in [0, 1]");
  return true;
}

Pose PerturbExtrinsic(const Pose& T, const Eigen::Vector3d& rpy) {
  Pose out = T;
  out.linear() = T.linear() * RotationFromRpy(rpy.x(), rpy.y(), rpy.z());
  return out;
}

GridSearch::GridSearch(const GridSearchConfig& config, const RangeImage& projection,
                       const std::vector<BoardGeometry>& boards)
    : config_(config), projection_(projection), boards_(boards) {}

// Alg. 1, CalculateROI: the range-image rectangle covering a cube of the board's side centred on
// the predicted board centre. Rather than projecting the cube's 8 vertices (16 arctangents and 8
// cell look-ups per region and candidate), the centre's direction is widened by the cube's
// angular half-extents: seen from azimuth az, the cube's horizontal cross-section is
// w = h (|cos az| + |sin az|) wide on either side and as deep, so the half-widths are
// atan(w / (d - w)) in azimuth (d horizontal distance) and atan(h / (r - w)) in elevation
// (r range): 2 arctangents and 2 look-ups, and the same rectangle as the vertices give to
// within a cell (the brute-force oracle in the tests uses the same regions).
bool GridSearch::RegionOf(const Eigen::Vector3d& c, double side, Roi* roi) const {
  const double h = side / 2.0;
  const double horizontal = std::sqrt(c.x() * c.x() + c.y() * c.y());
  const double w = horizontal > 0.0 ? h * (std::abs(c.x()) + std::abs(c.y())) / horizontal : h;
  const double range = std::sqrt(horizontal * horizontal + c.z() * c.z());
  if (horizontal <= 2.0 * w) return false;  // the sensor is (nearly) inside the box
  const double az = FastAtan2(static_cast<float>(c.y()), static_cast<float>(c.x()));
  const double el = FastAtan2(static_cast<float>(c.z()), static_cast<float>(horizontal));
  const double half_az = std::atan(w / (horizontal - w));
  const double half_el = std::atan(h / (range - w));
  // Clipped to the field of view: a near board's box reaches past it (a 1.5 m board spans
  // +-17 deg) and must still count with the part the LiDAR sees, or the search prefers
  // rotations that push boards inwards.
  if (!projection_.CellBoxOf(az - half_az, az + half_az, el - half_el, el + half_el, &roi->row_lo,
                             &roi->row_hi, &roi->col_lo, &roi->col_hi))
    return false;
  // A region straddling the azimuth seam of a 360-degree image would look inverted: boards sit in
  // front of the camera, never behind the LiDAR, so such a region is treated as empty.
  return roi->col_hi >= roi->col_lo && roi->col_hi - roi->col_lo < projection_.cols() / 2;
}

bool GridSearch::BoardRegion(const SessionObservations::CameraBoard& cam,
                             const Pose& T_lidar_camera, Roi* roi, double* range_lo,
                             double* range_hi) const {
  if (cam.board_index < 0 || cam.board_index >= static_cast<int>(boards_.size())) return false;
  const BoardGeometry& g = boards_[cam.board_index];
  const Eigen::Vector3d centre = T_lidar_camera * cam.T_camera_board.translation();
  const double side = std::max(g.width_m, g.height_m);
  const double range = centre.norm();
  const double reach = side + 0.05 * range;
  *range_lo = range - reach;
  *range_hi = range + reach;
  return RegionOf(centre, side, roi);
}

double GridSearch::ClusterRange(const SessionObservations& s,
                                const SessionObservations::LidarCluster& c) {
  double sum = 0.0;
  for (int i = 0; i < c.num_points; ++i) sum += s.points[c.first_point + i].cast<double>().norm();
  return c.num_points > 0 ? sum / c.num_points : 0.0;
}

void GridSearch::Prepare(const SessionObservations& s) {
  grids_.clear();
  integral_.clear();
  frame_first_cluster_.assign(static_cast<size_t>(s.num_frames) + 1, 0);
  for (const auto& c : s.lidar) {
    ClusterGrid g{c.frame,
                  std::numeric_limits<int>::max(),
                  std::numeric_limits<int>::max(),
                  0,
                  0,
                  integral_.size(),
                  ClusterRange(s, c),
                  Eigen::Vector3d::Zero()};
    for (int i = 0; i < c.num_points; ++i) g.centroid += s.points[c.first_point + i].cast<double>();
    if (c.num_points > 0) g.centroid /= c.num_points;
    int row_hi = std::numeric_limits<int>::min(), col_hi = std::numeric_limits<int>::min();
    std::vector<std::pair<int, int>>& cells = cells_;
    cells.clear();
    // A frame not taking part keeps an empty grid (counts 0).
    const int points = Rank(c.frame, s.num_frames) >= 0 ? c.num_points : 0;
    for (int i = 0; i < points; ++i) {
      int row = 0, col = 0;
      if (!CellOfPoint(projection_, s.points[c.first_point + i].cast<double>(), &row, &col))
        continue;
      cells.emplace_back(row, col);
      g.row0 = std::min(g.row0, row);
      g.col0 = std::min(g.col0, col);
      row_hi = std::max(row_hi, row);
      col_hi = std::max(col_hi, col);
    }
    if (cells.empty()) {
      g.row0 = g.col0 = 0;
    } else {
      g.rows = row_hi - g.row0 + 1;
      g.cols = col_hi - g.col0 + 1;
    }
    // Integral image with a zero first row and column: I(r+1, c+1) = count in [0..r] x [0..c].
    integral_.resize(integral_.size() + static_cast<size_t>((g.rows + 1) * (g.cols + 1)), 0);
    int32_t* I = integral_.data() + g.offset;
    for (const auto& rc : cells)
      ++I[(rc.first - g.row0 + 1) * (g.cols + 1) + (rc.second - g.col0 + 1)];
    for (int r = 1; r <= g.rows; ++r)
      for (int col = 1; col <= g.cols; ++col)
        I[r * (g.cols + 1) + col] += I[(r - 1) * (g.cols + 1) + col] +
                                     I[r * (g.cols + 1) + col - 1] -
                                     I[(r - 1) * (g.cols + 1) + col - 1];
    grids_.push_back(g);
  }
  // Clusters are in frame order: index the first cluster of every frame.
  size_t k = 0;
  for (int f = 0; f <= s.num_frames; ++f) {
    while (k < grids_.size() && grids_[k].frame < f) ++k;
    frame_first_cluster_[static_cast<size_t>(f)] = static_cast<int>(k);
  }
}

long GridSearch::InViewPoints(const SessionObservations& s, const Pose& T_prior) {
  auto off_axis = [](const Eigen::Vector3d& p_camera) {
    return std::atan2(p_camera.head<2>().norm(), p_camera.z());
  };
  std::vector<char>& has_board = frame_has_board_;
  has_board.assign(static_cast<size_t>(s.num_frames), 0);
  double widest = 0.0;
  for (const auto& cam : s.camera) {
    if (Rank(cam.frame, s.num_frames) < 0) continue;
    has_board[static_cast<size_t>(cam.frame)] = 1;
    widest = std::max(widest, off_axis(cam.T_camera_board.translation()));
  }
  const double reach = config_.range_deg + (config_.refine ? config_.refine_range_deg : 0.0);
  const double cone = widest + (reach + kViewConeMarginDeg) * kDeg2Rad;
  long total = 0;
  for (size_t k = 0; k < grids_.size(); ++k) {
    const ClusterGrid& g = grids_[k];
    if (Rank(g.frame, s.num_frames) < 0 || !has_board[static_cast<size_t>(g.frame)]) continue;
    if (off_axis(T_prior * g.centroid) <= cone) total += s.lidar[k].num_points;
  }
  return total;
}

long GridSearch::ClusterCount(const ClusterGrid& g, const Roi& roi) const {
  const int r0 = std::max(roi.row_lo, g.row0) - g.row0,
            r1 = std::min(roi.row_hi, g.row0 + g.rows - 1) - g.row0;
  const int c0 = std::max(roi.col_lo, g.col0) - g.col0,
            c1 = std::min(roi.col_hi, g.col0 + g.cols - 1) - g.col0;
  if (r0 > r1 || c0 > c1) return 0;
  const int32_t* I = integral_.data() + g.offset;
  const int w = g.cols + 1;
  return I[(r1 + 1) * w + (c1 + 1)] - I[r0 * w + (c1 + 1)] - I[(r1 + 1) * w + c0] + I[r0 * w + c0];
}

long GridSearch::CountFast(const SessionObservations& s, const Pose& T_camera_lidar,
                           std::vector<int>* best_cluster, int frame_stride) const {
  const Pose T_lidar_camera = T_camera_lidar.inverse();
  long total = 0;
  for (size_t b = 0; b < s.camera.size(); ++b) {
    const auto& cam = s.camera[b];
    if (best_cluster) (*best_cluster)[b] = -1;
    const int rank = Rank(cam.frame, s.num_frames);
    if (rank < 0 || rank % frame_stride != 0) continue;
    Roi roi;
    double range_lo = 0.0, range_hi = 0.0;
    if (!BoardRegion(cam, T_lidar_camera, &roi, &range_lo, &range_hi)) continue;
    long best = 0;
    for (int k = frame_first_cluster_[cam.frame]; k < frame_first_cluster_[cam.frame + 1]; ++k) {
      if (grids_[k].range_m < range_lo || grids_[k].range_m > range_hi) continue;
      const long n = ClusterCount(grids_[k], roi);
      total += n;
      if (best_cluster && n > best) {
        best = n;
        (*best_cluster)[b] = k;
      }
    }
  }
  return total;
}

long GridSearch::CountBruteForce(const SessionObservations& s, const Pose& T_camera_lidar) const {
  const Pose T_lidar_camera = T_camera_lidar.inverse();
  long total = 0;
  for (const auto& cam : s.camera) {
    Roi roi;
    double range_lo = 0.0, range_hi = 0.0;
    if (!BoardRegion(cam, T_lidar_camera, &roi, &range_lo, &range_hi)) continue;
    for (const auto& c : s.lidar) {
      if (c.frame != cam.frame) continue;
      const double range = ClusterRange(s, c);
      if (range < range_lo || range > range_hi) continue;
      for (int i = 0; i < c.num_points; ++i) {
        int row = 0, col = 0;
        if (!CellOfPoint(projection_, s.points[c.first_point + i].cast<double>(), &row, &col))
          continue;
        total += (row >= roi.row_lo && row <= roi.row_hi && col >= roi.col_lo && col <= roi.col_hi)
                     ? 1
                     : 0;
      }
    }
  }
  return total;
}

GridSearchResult GridSearch::Run(const SessionObservations& s, const Pose& T_prior,
                                 ObservationSet* correspondences, int max_frames, int threads) {
  const auto t0 = std::chrono::steady_clock::now();
  GridSearchResult result;
  result.T_camera_lidar = T_prior;
  std::string why;
  if (!config_.IsValid(&why)) {
    result.status = GridSearchResult::Status::kNoInput;
    result.reason = "config: " + why;
    return result;
  }
  if (s.camera.empty() || s.lidar.empty()) {
    result.reason = s.camera.empty() ? "no camera board detections" : "no LiDAR board clusters";
    return result;
  }
  max_frames_ = max_frames;
  Prepare(s);
  result.total_points = InViewPoints(s, T_prior);
  result.prior_count = CountFast(s, T_prior, nullptr);
  const int taking_part = max_frames > 0 && max_frames < s.num_frames ? max_frames : s.num_frames;
  const int stride =
      config_.max_scoring_frames > 0
          ? std::max(1, (taking_part + config_.max_scoring_frames - 1) / config_.max_scoring_frames)
          : 1;

  // One pass over a cube of perturbations centred on `centre`; candidates in a fixed order, a tie
  // keeps the one closest to the centre (then the earlier one): deterministic, biased to the prior.
  // The candidates are counted in slices on `threads` threads, then compared in their order.
  Eigen::Vector3d best_rpy = Eigen::Vector3d::Zero();
  long best_count = -1;
  std::vector<long> counts;
  auto pass = [&](const Eigen::Vector3d& centre, double range_deg, double step_deg) {
    const int n = static_cast<int>(std::floor(range_deg / step_deg + 1e-9));
    const int side = 2 * n + 1, candidates = side * side * side;
    const auto offset = [&](int c) -> Eigen::Vector3d {
      const int i = c / (side * side) - n, j = (c / side) % side - n, k = c % side - n;
      return Eigen::Vector3d(i * step_deg * kDeg2Rad, j * step_deg * kDeg2Rad,
                             k * step_deg * kDeg2Rad);
    };
    counts.assign(static_cast<size_t>(candidates), 0);
    const int slices = 4 * std::max(1, threads);
    ParallelFor(threads, slices, [&](int, int slice) {
      for (int c = candidates * slice / slices; c < candidates * (slice + 1) / slices; ++c)
        counts[static_cast<size_t>(c)] =
            CountFast(s, PerturbExtrinsic(T_prior, centre + offset(c)), nullptr, stride);
    });
    result.candidates += candidates;
    Eigen::Vector3d pass_best = centre;
    long pass_count = -1;
    double pass_norm = 0.0;
    for (int c = 0; c < candidates; ++c) {
      const Eigen::Vector3d d = offset(c);
      const long count = counts[static_cast<size_t>(c)];
      if (count > pass_count || (count == pass_count && d.norm() < pass_norm)) {
        pass_count = count;
        pass_best = centre + d;
        pass_norm = d.norm();
      }
    }
    if (pass_count > best_count) {
      best_count = pass_count;
      best_rpy = pass_best;
    }
  };
  pass(Eigen::Vector3d::Zero(), config_.range_deg, config_.step_deg);
  if (config_.refine) pass(best_rpy, config_.refine_range_deg, config_.refine_step_deg);

  // Report the winner's count over every frame (the gate below compares with all points).
  best_count = CountFast(s, PerturbExtrinsic(T_prior, best_rpy), nullptr);
  result.best_count = best_count;
  result.perturbation_rpy_deg = best_rpy / kDeg2Rad;
  const long needed = std::max<long>(
      config_.min_points,
      static_cast<long>(config_.min_point_fraction * static_cast<double>(result.total_points)));
  if (best_count < needed) {
    result.status = GridSearchResult::Status::kNoCandidate;
    result.reason = "best candidate puts " + std::to_string(best_count) +
                    " LiDAR board points in the camera boards' regions, fewer than " +
                    std::to_string(needed);
  } else {
    result.status = GridSearchResult::Status::kOk;
    result.T_camera_lidar = PerturbExtrinsic(T_prior, best_rpy);
    if (correspondences) {
      std::vector<int> best_cluster(s.camera.size(), -1);
      CountFast(s, result.T_camera_lidar, &best_cluster);
      std::vector<bool> used(grids_.size(), false);
      for (size_t b = 0; b < s.camera.size(); ++b) {
        const int k = best_cluster[b];
        if (k < 0 || used[k]) continue;  // frames not taking part have no best cluster
        used[k] = true;
        BoardObservation o;
        o.frame = s.camera[b].frame;
        o.board_index = s.camera[b].board_index;
        o.T_camera_board = s.camera[b].T_camera_board;
        o.corners_px = s.camera[b].corners_px;
        o.outline = s.camera[b].outline;
        o.lidar_cluster = k;
        const int first = s.lidar[k].first_point;
        correspondences->Add(
            o, s.points.data() + first,
            s.point_dt.size() == s.points.size() ? s.point_dt.data() + first : nullptr,
            s.lidar[k].num_points);
      }
    }
  }
  result.search_ms = MsSince(t0);
  return result;
}

}  // namespace calibd
