#include "calibd/core/calibration_engine.hpp"

#include "calibd/core/board_swap_check.hpp"
#include "calibd/core/stopwatch.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>
#include <numeric>
#include <random>
#include <set>
#include <sstream>

#include "calibd/core/board_distances.hpp"
#include "calibd/core/board_fit.hpp"
#include "calibd/core/board_flatness.hpp"
#include "calibd/core/parallel_for.hpp"
#include "calibd/core/range_offset.hpp"
#include "calibd/core/ring_elevations.hpp"
#include "calibd/core/stats.hpp"
#include "calibd/core/text_format.hpp"
#include "verdict_gates.hpp"

namespace calibd {

namespace {

using detail::FailedGate;
using detail::kStartCheckRotationDeg;
using detail::kStartCheckTranslationM;

CalibrationOutcome Reject(CalibrationOutcome out, Reason reason, const std::string& detail) {
  out.verdict = CalibrationOutcome::Verdict::kRejected;
  out.reason = reason;
  out.detail = detail;
  return out;
}

// Paper Table I metric over all observations: mean and p95 of the fitted corners' pixel errors.
// Paper Table I errors of observations [begin, end) of `set` into errors_px[4k .. 4k+3] (NaN
// where a corner has none). `T_camera_board_start` (one per observation, or empty): where each
// board's fit starts.
void ReprojectionErrors(const std::vector<BoardGeometry>& boards, const CameraModel& camera,
                        const ObservationSet& set, const Pose& T_cl,
                        const DirectOptimizerConfig& direct,
                        const std::vector<Pose>& T_camera_board_start, size_t begin, size_t end,
                        double* errors_px) {
  const bool warm = T_camera_board_start.size() == set.observations.size();
  std::array<Eigen::Vector2d, 4> px;
  for (size_t k = begin; k < end; ++k) {
    const BoardObservation& o = set.observations[k];
    const bool fitted = FittedTagCornersPx(camera, boards, set, o, T_cl, direct, &px,
                                           warm ? &T_camera_board_start[k] : nullptr);
    for (int c = 0; c < 4; ++c)
      errors_px[4 * k + c] = fitted && px[c].allFinite() ? (px[c] - o.corners_px[c]).norm()
                                                         : std::numeric_limits<double>::quiet_NaN();
  }
}

void ReprojectionFigures(std::vector<double> errors_px, QualityFigures* q) {
  errors_px.erase(
      std::remove_if(errors_px.begin(), errors_px.end(), [](double e) { return std::isnan(e); }),
      errors_px.end());
  if (errors_px.empty()) return;
  q->reprojection_mean_px = std::accumulate(errors_px.begin(), errors_px.end(), 0.0) /
                            static_cast<double>(errors_px.size());
  q->reprojection_p95_px = Quantile(errors_px, 0.95);
}

void CoverageFigures(const CalibConfig& config, const ObservationSet& set, QualityFigures* q) {
  const CameraModel camera(config.camera);
  std::set<int> frames, cells;
  q->min_distance_m = 1e9;
  q->max_distance_m = 0.0;
  const double f = 0.5 * (config.camera.fx + config.camera.fy);
  double spacing_sum = 0.0;
  int spaced = 0;
  for (const auto& o : set.observations) {
    frames.insert(o.frame);
    const double d = o.T_camera_board.translation().norm();
    if (o.num_points > 0 && d > 0.0 && o.board_index >= 0 &&
        o.board_index < static_cast<int>(config.boards.size())) {
      const BoardGeometry& b = config.boards[static_cast<size_t>(o.board_index)];
      spacing_sum += f * std::sqrt(b.width_m * b.height_m / o.num_points) / d;
      ++spaced;
    }
    q->min_distance_m = std::min(q->min_distance_m, d);
    q->max_distance_m = std::max(q->max_distance_m, d);
    Eigen::Vector2d uv;
    if (camera.Project(o.T_camera_board.translation(), &uv, 1e6)) {
      // A centre projected just outside the image counts in the nearest border cell.
      const double w = config.camera.width, h = config.camera.height;
      cells.insert(ImageCell(std::clamp(uv.x(), 0.0, std::nextafter(w, 0.0)),
                             std::clamp(uv.y(), 0.0, std::nextafter(h, 0.0)), config.camera.width,
                             config.camera.height));
    }
  }
  if (set.observations.empty()) q->min_distance_m = 0.0;
  q->frames_used = static_cast<int>(frames.size());
  q->boards_used = static_cast<int>(set.observations.size());
  q->lidar_spacing_px = spaced > 0 ? spacing_sum / spaced : 0.0;
  q->image_coverage =
      static_cast<double>(cells.size()) / static_cast<double>(kImageGridSide * kImageGridSide);
}

// Formal standard deviations: covariance = sigma^2 (J^T J)^-1 with sigma the residual RMS, in the
// tangent [dt, dtheta]; the worst direction of each block.
void FormalSigmas(const Eigen::Matrix<double, 6, 6>& info, double residual_rms, QualityFigures* q) {
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(info);
  if (!lu.isInvertible()) {
    q->rotation_sigma_deg = q->translation_sigma_m = std::numeric_limits<double>::infinity();
    return;
  }
  const Eigen::Matrix<double, 6, 6> cov = lu.inverse() * residual_rms * residual_rms;
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> et(cov.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(cov.bottomRightCorner<3, 3>());
  q->translation_sigma_m = std::sqrt(std::max(0.0, et.eigenvalues()(2)));
  q->rotation_sigma_deg = std::sqrt(std::max(0.0, er.eigenvalues()(2))) * kRad2Deg;
}

// A correspondence is not its board's when, at the solution, the centroid of its LiDAR points
// lies outside the board's outline or farther from its plane than kFitSigmas range noise sigmas:
// the grid search paired the camera's board with furniture in its predicted region. The centroid,
// not each point: a far board's edge returns spill beyond its outline by a beam footprint.
constexpr double kFitSigmas = 3.0;
// Drop-and-solve rounds at most.
constexpr int kMaxDropRounds = 3;

// Start `k` of the start checks: the solution turned by kStartCheckRotationDeg and moved by
// kStartCheckTranslationM along fixed directions that differ from check to check.
Pose StartCheckPose(const Pose& T_camera_lidar, int k) {
  static const Eigen::Vector3d kAxes[] = {{1, 1, 0}, {0, -1, 1}, {-1, 0, 1}, {1, -1, -1}};
  const Eigen::Vector3d axis = kAxes[k % 4].normalized();
  Pose start = T_camera_lidar;
  start.linear() =
      RotationFromAxisAngle(axis, kStartCheckRotationDeg / kRad2Deg) * T_camera_lidar.linear();
  start.translation() += kStartCheckTranslationM * Eigen::Vector3d(axis.z(), axis.x(), axis.y());
  return start;
}

// Per observation, whether its points' centroid fits its board (above) with the extrinsic and
// board poses of `direct`. The noise sigma is the median over the boards of their points' RMS
// distance to their plane: most boards are right, a wrong one does not move the median.
std::vector<char> BoardsThatFit(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                                const DirectResult& direct) {
  const size_t n = set.observations.size();
  std::vector<char> fits(n, 1);
  if (direct.T_camera_board.size() != n) return fits;
  std::vector<double> rms(n, 0.0);
  std::vector<Eigen::Vector3d> centroid(n, Eigen::Vector3d::Zero());
  for (size_t i = 0; i < n; ++i) {
    const BoardObservation& o = set.observations[i];
    if (o.num_points == 0) continue;
    const Pose T_board_lidar = direct.T_camera_board[i].inverse() * direct.T_camera_lidar;
    double sum = 0.0;
    for (int k = o.first_point; k < o.first_point + o.num_points; ++k) {
      const Eigen::Vector3d q = T_board_lidar * set.points[static_cast<size_t>(k)].cast<double>();
      centroid[i] += q;
      sum += q.z() * q.z();
    }
    centroid[i] /= o.num_points;
    rms[i] = std::sqrt(sum / o.num_points);
  }
  const double max_z = kFitSigmas * std::max(Median(rms), 0.005);
  for (size_t i = 0; i < n; ++i) {
    const BoardGeometry& g = boards[static_cast<size_t>(set.observations[i].board_index)];
    const Eigen::Vector3d& c = centroid[i];
    fits[i] = std::fabs(c.z()) <= max_z && std::fabs(c.x()) <= 0.5 * g.width_m &&
              std::fabs(c.y()) <= 0.5 * g.height_m;
  }
  return fits;
}

// The verdict's count gates on the correspondences: a rejection when too few frame pairs or
// boards have one, `after` telling when they were counted; kNone otherwise.
Reason TooFewCorrespondences(const QualityFigures& q, const VerdictConfig& v,
                             const std::string& after, std::string* detail) {
  if (q.frames_used < v.min_frames) {
    *detail = std::to_string(q.frames_used) + " frame pairs with a correspondence" + after + ", " +
              std::to_string(v.min_frames) + " needed";
    return Reason::kTooFewFrames;
  }
  if (q.boards_used < v.min_boards) {
    *detail = std::to_string(q.boards_used) + " board correspondences" + after + ", " +
              std::to_string(v.min_boards) + " needed";
    return Reason::kTooFewBoards;
  }
  return Reason::kNone;
}

// Drops from `set` the observations whose points do not fit their board (BoardsThatFit) at
// `direct`'s solution; returns how many.
int DropBoardsThatDoNotFit(const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                           ObservationSet* set) {
  return set->KeepOnly(BoardsThatFit(boards, *set, direct));
}

}  // namespace

CameraScaleEstimate EstimateCameraScale(const ObservationSet& set,
                                        const std::vector<BoardDistance>& rows) {
  CameraScaleEstimate est;
  if (static_cast<int>(rows.size()) < kMinScaleBoards) return est;
  // While driving, what is left of the camera's time offset adds tau (n . v) (board_motion.hpp):
  // fitted beside the scale where the boards' velocities are known, or a camera corrected for a
  // large offset would leave part of it to the scale.
  const bool timed = HasTimeOffsetTerm(set, rows);
  const int k = timed ? 5 : 4;
  DistanceFitter scale(k), range(k + 1);
  double near = rows[0].camera_m, far = rows[0].camera_m, distance = 0.0;
  Eigen::VectorXd a(k + 1);
  for (const BoardDistance& b : rows) {
    const Eigen::Vector3d& n = b.normal;
    const BoardObservation& o = *b.observation;
    // Unweighted: near the boards the LiDAR's own scatter, not PnP's, limits a row (weighting by
    // PnP's error, as the time offset does, put a clean still session's scale and range offset
    // at 8 and 4 sigma on the nearest boards).
    a.head<4>() << b.camera_m, n.x(), n.y(), n.z();
    if (timed) a(4) = o.has_velocity ? n.dot(o.velocity) : 0.0;
    const double y = b.camera_m - b.lidar_m;
    scale.Add(o, a.head(k), y);
    a(k) = -n.dot(b.mean_ray);
    range.Add(o, a, y);
    near = std::min(near, b.camera_m);
    far = std::max(far, b.camera_m);
    distance += b.camera_m;
  }
  est.distance_m = distance / static_cast<double>(rows.size());
  const DistanceFit r = range.Fit();
  if (r.fitted) {
    est.range_offset_fitted = true;
    est.range_offset_m = r.x(k);
    est.range_offset_sigma_m = r.Sigma(k, kMinScaleClusterBlocks);
  }
  // A scale shows only over a spread of distances: boards all at one distance leave it to the
  // translation (the fit would be noise). With the range offset beside it where the boards'
  // directions can tell that from a translation: still poses near and far would otherwise take
  // part of a range offset for a scale.
  if (far - near < kMinScaleDistanceSpread * far) return est;
  const DistanceFit& fit = r.fitted ? r : scale.Fit();
  if (fit.fitted) {
    est.scale_fitted = true;
    est.scale = fit.x(0);
    est.scale_sigma = fit.Sigma(0, kMinScaleClusterBlocks);
  }
  return est;
}

void ScaleCameraPatterns(double factor, std::vector<BoardGeometry>* boards, ObservationSet* set) {
  for (BoardGeometry& g : *boards) {
    g.tag_size_m *= factor;
    g.checker_square_size_m *= factor;
  }
  for (BoardObservation& o : set->observations) {
    o.T_camera_board.translation() *= factor;
    o.velocity *= factor;
  }
}

bool FittedTagCornersPx(const CameraModel& camera, const std::vector<BoardGeometry>& boards,
                        const ObservationSet& set, const BoardObservation& o, const Pose& T_cl,
                        const DirectOptimizerConfig& direct, std::array<Eigen::Vector2d, 4>* px,
                        const Pose* T_camera_board_start) {
  const BoardGeometry& g = boards[o.board_index];
  const Pose& start = T_camera_board_start ? *T_camera_board_start : o.T_camera_board;
  // Started from the refined (or PnP) pose, the fit needs no more than the figures' precision: it
  // stops when an iteration changes the cost by < 1e-4 or the pose by < 1e-6 (6 um at 6 m), or at
  // 15 iterations (a few boards' hinge keeps it stepping along an edge). Simulated ot128 drive,
  // 600 boards: 11.5 -> 6.4 iterations on average, mean reprojection 3.07 -> 2.99 px. Every point
  // is used: strided to 256 like the solve, the fitted corners moved it to 3.62 px.
  constexpr int kMaxIterations = 15;
  constexpr double kFunctionTolerance = 1e-4, kParameterTolerance = 1e-6;
  const BoardFitResult fit =
      FitBoardPose(set.points.data() + o.first_point, o.num_points, g.width_m / 2.0,
                   g.height_m / 2.0, direct.alpha_m, direct.huber_m, T_cl.inverse() * start,
                   kMaxIterations, kFunctionTolerance, kParameterTolerance);
  if (!fit.usable) return false;
  const auto corners = g.TagCornersInBoard();
  for (int c = 0; c < 4; ++c) {
    if (!camera.Project(T_cl * fit.T_lidar_board * corners[c], &(*px)[c], 1e6))
      (*px)[c] = Eigen::Vector2d::Constant(std::numeric_limits<double>::quiet_NaN());
  }
  return true;
}

int ImageCell(double u_px, double v_px, int width, int height) {
  if (!(u_px >= 0.0 && u_px < width && v_px >= 0.0 && v_px < height)) return -1;
  const int col = static_cast<int>(u_px * kImageGridSide / width);
  const int row = static_cast<int>(v_px * kImageGridSide / height);
  return row * kImageGridSide + col;
}

const char* VerdictName(CalibrationOutcome::Verdict v) {
  switch (v) {
    case CalibrationOutcome::Verdict::kVerified:
      return "verified";
    case CalibrationOutcome::Verdict::kUpdated:
      return "updated";
    case CalibrationOutcome::Verdict::kRejected:
      return "rejected";
  }
  return "rejected";
}

namespace {

// The frame pairs in capture order, each once: the order a session holds them in is their arrival
// order, which a log written out of order or a replay that sends pairs twice does not keep, and
// motion compensation finds a board's neighbours in time among the adjacent frames, while a pair
// counted twice would weigh double and sit in both halves of a half-data re-solve. Empty when
// `s` is already so, or carries no capture times (pairs by file name) to order by.
std::vector<int> CaptureOrder(const SessionObservations& s, int* out_of_order, int* duplicates) {
  *out_of_order = *duplicates = 0;
  const auto& t = s.frame_times;
  if (static_cast<int>(t.size()) != s.num_frames ||
      std::all_of(t.begin(), t.end(), [](const FrameTimes& f) { return f.camera_utime == 0; }))
    return {};
  auto same = [&](size_t a, size_t b) {
    return t[a].camera_utime == t[b].camera_utime && t[a].lidar_utime == t[b].lidar_utime;
  };
  bool in_order_once = true;  // checked without allocating: the usual case
  for (size_t f = 1; f < t.size(); ++f) {
    *out_of_order += t[f].camera_utime < t[f - 1].camera_utime;
    in_order_once = in_order_once && t[f].camera_utime >= t[f - 1].camera_utime && !same(f, f - 1);
  }
  if (in_order_once) return {};
  std::vector<int> order(t.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return t[a].camera_utime < t[b].camera_utime; });
  std::vector<int> once;
  once.reserve(order.size());
  for (const int f : order) {
    if (!once.empty() && same(static_cast<size_t>(once.back()), static_cast<size_t>(f))) {
      ++*duplicates;
      continue;
    }
    once.push_back(f);
  }
  return once;
}

/// The detail of a `board_ids_swapped` refusal: `claim` boards A and B "are each other's
/// (`evidence`)", and what to do.
std::string SwappedBoardsDetail(const std::vector<BoardGeometry>& boards, const BoardSwap& swap,
                                const std::string& claim, const std::string& evidence) {
  const BoardGeometry& a = boards[static_cast<size_t>(swap.board_a)];
  const BoardGeometry& b = boards[static_cast<size_t>(swap.board_b)];
  auto name = [](const BoardGeometry& g) {
    return std::to_string(g.board_id) + " (tag id " + std::to_string(g.tag_id) + ", " +
           FixedDecimal(g.width_m, 3) + " x " + FixedDecimal(g.height_m, 3) + " m)";
  };
  return claim + " boards " + name(a) + " and " + name(b) + " are each other's (" + evidence +
         "): the configuration gives each of them the other's id or sizes; check which id is "
         "printed on which board and correct the configuration";
}

// What the engine cannot work from at all: an invalid engine config, clouds of another LiDAR
// model, no board seen by one of the sensors. kNone, or the reason with `detail`.
Reason CheckInputs(const CalibConfig& config, const SessionObservations& observed,
                   const EngineConfig& engine, std::string* detail) {
  auto refuse = [detail](Reason reason, std::string text) {
    *detail = std::move(text);
    return reason;
  };
  std::string why;
  if (!engine.grid.IsValid(&why) || !engine.motion.IsValid(&why) || !engine.direct.IsValid(&why) ||
      !engine.scenery.IsValid(&why))
    return refuse(Reason::kInvalidConfig, "engine config: " + why);
  if (observed.lidar_valid_points > 0 &&
      static_cast<double>(observed.lidar_outside_points) >
          kMaxLidarOutsideShare * static_cast<double>(observed.lidar_valid_points))
    return refuse(
        Reason::kLidarModelMismatch,
        FixedDecimal(100.0 * static_cast<double>(observed.lidar_outside_points) /
                         static_cast<double>(observed.lidar_valid_points),
                     1) +
            " % of the LiDAR's points fall outside the field of view of the configured model (" +
            config.lidar_model +
            "): the clouds come from another LiDAR, or in other axes (x forward, z up), than the "
            "configuration says; configure the model that recorded them (calibd-calibrate "
            "--inspect estimates one), or 'generic'");
  if (observed.camera.empty())
    return refuse(Reason::kNoCameraBoards, "the camera saw no configured board in any frame pair");
  if (observed.lidar.empty())
    return refuse(Reason::kNoLidarBoards, "the LiDAR found no board cluster in any frame pair");

  return Reason::kNone;
}

// The coarse grid search (paper §III-D) around the prior: its extrinsic and the correspondences
// it pairs. When no rotation in its range aligns the boards, whether one does with two boards'
// ids swapped (board_swap_check.hpp). kNone, or the reason with `detail`.
Reason SearchGrid(const CalibConfig& config, const SessionObservations& session,
                  const RangeImage& projection, const EngineConfig& engine,
                  GridSearchResult* result, ObservationSet* corr, std::string* detail) {
  auto refuse = [detail](Reason reason, std::string text) {
    *detail = std::move(text);
    return reason;
  };
  GridSearch grid(engine.grid, projection, config.boards);
  *result = grid.Run(session, config.prior_T_camera_lidar, corr, engine.max_solve_frames);
  if (result->status != GridSearchResult::Status::kOk) {
    const BoardSwap swap = FindSwappedBoards(engine.grid, projection, config.boards, session,
                                             config.prior_T_camera_lidar, engine.max_solve_frames);
    if (!swap.found) return refuse(Reason::kNoGridCandidate, result->reason);
    return refuse(Reason::kBoardIdsSwapped,
                  SwappedBoardsDetail(config.boards, swap, "the LiDAR finds the boards only if",
                                      std::to_string(swap.grid.best_count) +
                                          " LiDAR board points in their regions then, too few "
                                          "without"));
  }
  return Reason::kNone;
}

// Each correspondence of a session without its static scenery names its cluster in the caller's
// session, not in the subset.
void NameClustersInTheSession(const SessionObservations& observed, const StaticScenery& scenery,
                              ObservationSet* corr) {
  if (scenery.num_scenery == 0) return;
  std::vector<int> original;
  original.reserve(observed.lidar.size());
  for (size_t j = 0; j < observed.lidar.size(); ++j)
    if (!scenery.scenery[j]) original.push_back(static_cast<int>(j));
  for (BoardObservation& o : corr->observations)
    if (o.lidar_cluster >= 0) o.lidar_cluster = original[static_cast<size_t>(o.lidar_cluster)];
}

// Enough correspondences after motion compensation, and camera distances that do not say two
// boards' ids are swapped (board_swap_check.hpp). kNone, or the reason with `detail`.
Reason CheckCorrespondences(const CalibConfig& config, const VerdictConfig& v,
                            const MotionCompensationStats& motion, const ObservationSet& corr,
                            const Pose& T_camera_lidar, const QualityFigures& q,
                            std::string* detail) {
  auto refuse = [detail](Reason reason, std::string text) {
    *detail = std::move(text);
    return reason;
  };
  std::string few;
  const std::string unmeasured =
      motion.dropped == 0
          ? ""
          : " once " + std::to_string(motion.dropped) +
                " whose board's motion the camera could not measure were dropped (the boards "
                "moved by " +
                FixedDecimal(motion.median_shift_m * 1e3, 0) + " mm between the sensors' times)";
  if (const Reason reason = TooFewCorrespondences(q, v, unmeasured, &few); reason != Reason::kNone)
    return refuse(reason, few);
  {
    const BoardSwap swap =
        FindSwapInDistances(config.boards, BoardDistances(corr, T_camera_lidar, &config.boards));
    if (swap.found)
      return refuse(
          Reason::kBoardIdsSwapped,
          SwappedBoardsDetail(config.boards, swap, "the camera's distances say",
                              "it puts them at " + FixedDecimal(swap.ratio_a, 2) + " and " +
                                  FixedDecimal(swap.ratio_b, 2) + " times the LiDAR's"));
  }

  return Reason::kNone;
}

// The solution: the direct optimisation (paper §III-E) or the indirect baseline, from the grid
// search's extrinsic, with the camera's time offset and scale corrected where they are measured
// and the boards that do not fit dropped. kNone, or the reason with `detail`.
struct Solution {
  DirectResult direct;
  /// The boards as the solve sees them: the configured ones, their patterns scaled when the
  /// camera's scale was corrected.
  std::vector<BoardGeometry> boards;
};

Reason Solve(const CalibConfig& config, const EngineConfig& engine, const CameraModel& camera,
             const Pose& T_start, ObservationSet* set, QualityFigures* quality, int* dropped_total,
             Solution* solution, std::string* detail) {
  auto refuse = [detail](Reason reason, std::string text) {
    *detail = std::move(text);
    return reason;
  };
  ObservationSet& corr = *set;
  QualityFigures& q = *quality;
  const VerdictConfig& v = engine.verdict;
  std::string few;
  std::vector<BoardGeometry>& boards = solution->boards;
  boards = config.boards;
  DirectResult& direct = solution->direct;
  if (engine.method == EngineConfig::Method::kIndirect) {
    const IndirectResult ind = OptimizeIndirect(boards, corr, camera, T_start, engine.indirect);
    if (!ind.usable) return refuse(Reason::kSolverFailed, "indirect method: " + ind.reason);
    direct = OptimizeDirect(boards, corr, ind.T_camera_lidar, engine.direct,
                            DirectSolveOptions::EvaluateOnly());
    direct.T_camera_lidar = ind.T_camera_lidar;
  } else {
    auto solve = [&] {
      return OptimizeDirect(boards, corr, T_start, engine.direct,
                            DirectSolveOptions::RefiningBoardPoses(camera));
    };
    // A camera running behind its stamps biases the solution along the boards' motion: its offset
    // is measured under the solution, the points moved to the camera's capture time, and solved
    // again (board_motion.hpp, EstimateTimeOffset).
    auto correct_time_offset = [&](const std::vector<BoardDistance>& distances) {
      const TimeOffsetEstimate t = EstimateTimeOffset(corr, distances);
      if (!t.fitted || std::fabs(t.offset_s) <= kTimeOffsetSigmas * t.sigma_s) return false;
      ShiftToCaptureTime(corr.time_offset_s + t.offset_s, direct.T_camera_lidar, &corr);
      direct = solve();
      return true;
    };
    // A tag printed at another size than configured (or a focal length off) scales every PnP
    // distance, which the translation would take up in proportion to the boards' distance: where
    // the boards' distances spread enough to measure it, the camera's patterns and distances are
    // scaled to the LiDAR's and the session solved again, as far as max_camera_scale_error
    // (beyond it the configuration is wrong, and the gate below refuses).
    auto correct_camera_scale = [&](const std::vector<BoardDistance>& distances) {
      const CameraScaleEstimate e = EstimateCameraScale(corr, distances);
      // Only a scale that would make the result wrong (kCorrectedScaleTolerances); once one
      // was corrected, what the second pass finds left of it counts beyond its sigma.
      const bool matters =
          q.camera_scale_corrected != 0.0 ||
          std::fabs(e.scale) * e.distance_m > kCorrectedScaleTolerances * v.verify_translation_m;
      if (!e.scale_fitted || std::fabs(e.scale) <= kScaleSigmas * e.scale_sigma || !matters)
        return false;
      const double total = (1.0 + q.camera_scale_corrected) * (1.0 + e.scale) - 1.0;
      if (std::fabs(total) > v.max_camera_scale_error) return false;
      ScaleCameraPatterns(1.0 / (1.0 + e.scale), &boards, &corr);
      q.camera_scale_corrected = total;
      direct = solve();
      return true;
    };
    // Both corrections once before dropping boards that do not fit (a large offset or scale
    // would make good boards look unfitting), and once after.
    auto correct = [&] {
      std::vector<BoardDistance> distances = BoardDistances(corr, direct.T_camera_lidar, &boards);
      if (correct_time_offset(distances)) {
        if (!direct.usable) return false;
        distances = BoardDistances(corr, direct.T_camera_lidar, &boards);
      }
      return !(correct_camera_scale(distances) && !direct.usable);
    };
    direct = solve();
    if (!direct.usable) return refuse(Reason::kSolverFailed, direct.reason);
    if (!correct()) return refuse(Reason::kSolverFailed, direct.reason);
    // A board paired with a cluster that is not on it pulls the solution: dropped, then solved
    // again without it, until none is dropped (a pulled solution can hide some at first).
    for (int round = 0; round < kMaxDropRounds; ++round) {
      const int dropped = DropBoardsThatDoNotFit(boards, direct, &corr);
      if (dropped == 0) break;
      *dropped_total += dropped;
      CoverageFigures(config, corr, &q);
      const std::string after = " once " + std::to_string(*dropped_total) +
                                " whose LiDAR points did not lie on their board were dropped";
      if (const Reason reason = TooFewCorrespondences(q, v, after, &few); reason != Reason::kNone)
        return refuse(reason, few);
      direct = solve();
      if (!direct.usable) return refuse(Reason::kSolverFailed, direct.reason);
    }
    if (!correct()) return refuse(Reason::kSolverFailed, direct.reason);
  }
  return Reason::kNone;
}

// The quality figures of a solution (QualityFigures): its formal sigmas and residual, the camera's
// scale and the LiDAR's range offset, ring elevations, board flatness, the principal point, the
// time offset left and the planes' conditioning.
void MeasureQuality(const CalibConfig& config, const SessionObservations& session,
                    const RangeImage& projection, const ObservationSet& corr,
                    const Solution& solution, const Pose& T_camera_lidar, QualityFigures* quality) {
  QualityFigures& q = *quality;
  const DirectResult& direct = solution.direct;
  const std::vector<BoardGeometry>& boards = solution.boards;
  q.residual_rms_m = direct.residual_rms_m;
  q.information = direct.information;
  q.min_information_eigenvalue = direct.min_information_eigenvalue;
  FormalSigmas(direct.information, direct.residual_rms_m, &q);
  const std::vector<BoardDistance> distances = BoardDistances(corr, T_camera_lidar, &boards);
  {
    const CameraScaleEstimate e = EstimateCameraScale(corr, distances);
    if (e.scale_fitted) {
      q.camera_scale_error = (1.0 + q.camera_scale_corrected) * (1.0 + e.scale) - 1.0;
      q.camera_scale_sigma = e.scale_sigma;
      q.camera_scale_translation_m = e.scale_sigma * e.distance_m;
    }
    if (e.range_offset_fitted) {
      q.lidar_range_offset_m = e.range_offset_m;
      q.lidar_range_offset_sigma_m = e.range_offset_sigma_m;
    }
    // The range offset from the plane distances alone where the boards face the LiDAR from varied
    // directions (still poses), or from the boards' in-plane centres too (range_offset.hpp),
    // which determine it while driving towards boards ahead, where the plane distances cannot:
    // whichever is the more precise. Over fewer than kMinScaleClusterBlocks blocks (still poses,
    // a sparse subset of a drive) the centres' sigma is a least-squares one only, which a few
    // poses held by people or beside clutter leave too small (a clean falcon session of 15
    // poses: 2.1 +-0.4 cm, the planes 1.2 +-0.5 cm): there the centres must be twice as precise
    // to be taken. Only here: the corrections use the scale alone.
    if (static_cast<int>(distances.size()) >= kMinScaleBoards) {
      const RangeOffsetFit centres =
          FitRangeOffset(distances, HasTimeOffsetTerm(corr, distances), kMinScaleClusterBlocks);
      const double centres_share = centres.blocks >= kMinScaleClusterBlocks ? 1.0 : 0.5;
      const double planes_sigma_m =
          e.range_offset_fitted ? e.range_offset_sigma_m : std::numeric_limits<double>::infinity();
      if (centres.fitted && centres.sigma_m < centres_share * planes_sigma_m) {
        q.lidar_range_offset_m = centres.offset_m;
        q.lidar_range_offset_sigma_m = centres.sigma_m;
      }
    }
  }
  {
    const RingElevationCheck rings =
        CheckRingElevations(boards, corr, projection, T_camera_lidar, direct.T_camera_board);
    if (rings.measured) {
      q.ring_elevation_rings = rings.rings;
      q.ring_elevation_rms_deg = rings.rms_deg;
      q.ring_elevation_chi2 = rings.chi2_per_ring;
    }
  }
  for (const BoardBend& b :
       EstimateBoardBends(boards, corr, T_camera_lidar, direct.T_camera_board)) {
    // Where both axes are measured, the one further from flat in its own sigmas.
    for (const auto& [bend, sigma] :
         {std::pair{b.bend_u_m, b.sigma_u_m}, std::pair{b.bend_v_m, b.sigma_v_m}}) {
      if (!std::isfinite(sigma)) continue;
      if (q.board_bend_id < 0 ||
          std::fabs(bend) / sigma > std::fabs(q.board_bend_m) / q.board_bend_sigma_m) {
        q.board_bend_id = boards[static_cast<size_t>(b.board_index)].board_id;
        q.board_bend_m = bend;
        q.board_bend_sigma_m = sigma;
      }
    }
  }
  {
    const auto t_pp = SteadyClock::now();
    const PrincipalPointEstimate pp = EstimatePrincipalPoint(config.camera, config.boards, session);
    q.principal_point_fitted = pp.fitted;
    q.principal_point_shift_px = pp.shift_px;
    q.principal_point_sigma_px = pp.sigma_px;
    q.principal_point_systematic_px = pp.systematic_px;
    q.principal_point_residual_px = pp.residual_rms_px;
    q.principal_point_turn_deg =
        std::hypot(pp.shift_px.x() / config.camera.fx, pp.shift_px.y() / config.camera.fy) *
        kRad2Deg;
    q.principal_point_ms = MsSince(t_pp);
  }
  {
    // What is left of the time offset after the corrections, added to what they applied.
    const TimeOffsetEstimate t = EstimateTimeOffset(corr, distances);
    q.time_offset_fitted = t.fitted;
    q.time_offset_s = corr.time_offset_s + (t.fitted ? t.offset_s : 0.0);
    q.time_offset_sigma_s = t.sigma_s;
    q.time_offset_corrected_s = corr.time_offset_s;
    q.board_normal_speed_mps = t.normal_speed_rms_mps;
  }
  {
    Eigen::Matrix<double, 6, 1> scale;
    scale << 1.0, 1.0, 1.0, 10.0, 10.0, 10.0;  // rad -> m at a 10 m lever arm
    const Eigen::Matrix<double, 6, 6> S = scale.cwiseInverse().asDiagonal() *
                                          direct.plane_information *
                                          scale.cwiseInverse().asDiagonal();
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(S);
    const double top = es.eigenvalues()(5);
    q.plane_conditioning = top > 0.0 ? std::max(0.0, es.eigenvalues()(0)) / top : 0.0;
  }
}

// The stability figures (re-solves on random halves, solves from other starts) and the
// reprojection errors (each board fitted alone, started from its refined pose): independent tasks
// shared out over the solver's threads. `reprojection_px`, when given, gets each
// correspondence's mean corner error.
void StabilityAndReprojection(const EngineConfig& engine, const std::vector<BoardGeometry>& boards,
                              const CameraModel& camera, const ObservationSet& corr,
                              const DirectResult& direct, const Pose& T_camera_lidar,
                              QualityFigures* quality, std::vector<double>* reprojection_px) {
  QualityFigures& q = *quality;
  const VerdictConfig& v = engine.verdict;
  const int runs = std::max(0, engine.stability_runs);
  std::mt19937_64 rng(12345);
  std::vector<std::vector<char>> use(runs, std::vector<char>(corr.observations.size()));
  for (auto& u : use)
    for (auto& b : u) b = static_cast<char>(rng() & 1u);
  std::vector<DirectResult> half(runs);
  const int starts = engine.method == EngineConfig::Method::kDirect ? engine.start_checks : 0;
  std::vector<DirectResult> started(static_cast<size_t>(std::max(0, starts)));
  DirectOptimizerConfig one = engine.direct;
  one.threads = 1;
  // Re-solves on random halves need the spread of the extrinsic over board subsets, not every
  // point of each board: half the points do.
  one.max_points_per_observation = std::max(3, one.max_points_per_observation / 2);
  one.max_points_per_solve /= 2;
  const int threads = std::max(1, engine.direct.threads);
  const size_t n = corr.observations.size();
  const int chunks = 4 * threads;
  std::vector<double> errors_px(4 * n);
  // Tasks [0, runs): re-solves on random halves (deterministic seed) from the full solution with
  // its board poses held, i.e. how far the extrinsic moves when half the boards are left out;
  // tasks [runs, runs + starts): solves of every board from other starts, board poses refined
  // again from the camera's (does the solve end in the same minimum?); then
  // [runs + starts, runs + starts + chunks): reprojection errors of a slice of the observations.
  ParallelFor(threads, runs + starts + chunks, [&](int, int task) {
    if (task < runs) {
      half[task] = ResolveWithHeldBoards(boards, corr, T_camera_lidar, one, direct.T_camera_board,
                                         &use[task]);
    } else if (task < runs + starts) {
      const int k = task - runs;
      started[static_cast<size_t>(k)] =
          OptimizeDirect(boards, corr, StartCheckPose(T_camera_lidar, k), one,
                         DirectSolveOptions::RefiningBoardPoses(camera));
    } else {
      const size_t c = static_cast<size_t>(task - runs - starts);
      ReprojectionErrors(boards, camera, corr, T_camera_lidar, engine.direct, direct.T_camera_board,
                         n * c / chunks, n * (c + 1) / chunks, errors_px.data());
    }
  });
  if (reprojection_px) {
    reprojection_px->assign(n, std::numeric_limits<double>::quiet_NaN());
    for (size_t k = 0; k < n; ++k) {
      double sum = 0.0;
      int corners = 0;
      for (size_t c = 4 * k; c < 4 * k + 4; ++c)
        if (!std::isnan(errors_px[c])) {
          sum += errors_px[c];
          ++corners;
        }
      if (corners > 0) (*reprojection_px)[k] = sum / corners;
    }
  }
  ReprojectionFigures(std::move(errors_px), &q);
  q.reprojection_gate_px =
      std::max(v.max_reprojection_mean_px, kReprojectionSpacingShare * q.lidar_spacing_px);
  for (const DirectResult& h : half) {
    if (!h.usable) continue;
    q.rotation_spread_deg =
        std::max(q.rotation_spread_deg,
                 RotationAngle(h.T_camera_lidar.linear(), T_camera_lidar.linear()) * kRad2Deg);
    q.translation_spread_m =
        std::max(q.translation_spread_m,
                 (h.T_camera_lidar.translation() - T_camera_lidar.translation()).norm());
  }
  for (size_t k = 0; k < started.size(); ++k) {
    // A solve that did not converge from there ended nowhere near: as far as its start.
    const DirectResult& r = started[k];
    const Pose end =
        r.usable ? r.T_camera_lidar : StartCheckPose(T_camera_lidar, static_cast<int>(k));
    q.start_rotation_deg = std::max(
        q.start_rotation_deg, RotationAngle(end.linear(), T_camera_lidar.linear()) * kRad2Deg);
    q.start_translation_m =
        std::max(q.start_translation_m, (end.translation() - T_camera_lidar.translation()).norm());
  }
}

CalibrationOutcome CalibrateInCaptureOrder(const CalibConfig& config,
                                           const SessionObservations& observed,
                                           const RangeImage& projection, const EngineConfig& engine,
                                           ObservationSet* correspondences,
                                           std::vector<double>* reprojection_px) {
  if (reprojection_px) reprojection_px->clear();
  CalibrationOutcome out;
  out.prior_T_camera_lidar = config.prior_T_camera_lidar;
  out.T_camera_lidar = config.prior_T_camera_lidar;
  const VerdictConfig& v = engine.verdict;
  std::string detail;
  if (const Reason reason = CheckInputs(config, observed, engine, &detail); reason != Reason::kNone)
    return Reject(out, reason, detail);

  // Clusters that stood still while the camera's boards moved are furniture (static_scenery.hpp).
  const StaticScenery scenery = FindStaticScenery(observed, config.boards, engine.scenery);
  out.static_scenery_clusters = scenery.num_scenery;
  SessionObservations moving;
  if (scenery.num_scenery > 0) {
    std::vector<char> keep(observed.lidar.size());
    for (size_t j = 0; j < keep.size(); ++j) keep[j] = !scenery.scenery[j];
    moving = Subset(observed, std::vector<char>(static_cast<size_t>(observed.num_frames), 1),
                    std::vector<char>(observed.camera.size(), 1), keep);
  }
  const SessionObservations& session = scenery.num_scenery > 0 ? moving : observed;
  if (session.lidar.empty())
    return Reject(out, Reason::kNoLidarBoards,
                  "every one of the " + std::to_string(scenery.num_scenery) +
                      " LiDAR board clusters stood still while the camera's boards moved "
                      "(furniture or walls, not boards): are the configured board sizes right, "
                      "and do the boards stand free, 0.3 m or more in front of anything?");

  ObservationSet local;
  ObservationSet& corr = correspondences ? *correspondences : local;
  corr.Reserve(static_cast<int>(session.camera.size()), static_cast<int>(session.points.size()));
  if (const Reason reason =
          SearchGrid(config, session, projection, engine, &out.grid, &corr, &detail);
      reason != Reason::kNone)
    return Reject(out, reason, detail);
  NameClustersInTheSession(observed, scenery, &corr);
  out.T_camera_lidar = out.grid.T_camera_lidar;
  out.motion = CompensateBoardMotion(session, out.grid.T_camera_lidar, engine.motion, &corr);
  CoverageFigures(config, corr, &out.quality);
  QualityFigures& q = out.quality;
  if (const Reason reason =
          CheckCorrespondences(config, v, out.motion, corr, out.grid.T_camera_lidar, q, &detail);
      reason != Reason::kNone)
    return Reject(out, reason, detail);

  const CameraModel camera(config.camera);
  const auto t_opt = SteadyClock::now();
  Solution solution;
  if (const Reason reason = Solve(config, engine, camera, out.grid.T_camera_lidar, &corr, &q,
                                  &out.dropped_correspondences, &solution, &detail);
      reason != Reason::kNone)
    return Reject(out, reason, detail);
  const DirectResult& direct = solution.direct;
  const std::vector<BoardGeometry>& boards = solution.boards;
  out.optimise_ms = MsSince(t_opt);
  out.T_camera_lidar = direct.T_camera_lidar;
  out.solved = true;
  out.refined_boards = direct.refined_boards;
  out.board_rotation_change_deg = direct.board_rotation_change_deg;
  out.board_translation_change_m = direct.board_translation_change_m;
  out.delta_rotation_deg =
      RotationAngle(config.prior_T_camera_lidar.linear(), out.T_camera_lidar.linear()) * kRad2Deg;
  out.delta_translation_m =
      (config.prior_T_camera_lidar.translation() - out.T_camera_lidar.translation()).norm();

  const auto t_q = SteadyClock::now();
  MeasureQuality(config, session, projection, corr, solution, out.T_camera_lidar, &q);
  StabilityAndReprojection(engine, boards, camera, corr, direct, out.T_camera_lidar, &q,
                           reprojection_px);
  out.quality_ms = MsSince(t_q);

  if (const Reason reason = FailedGate(config.camera, v, out, &detail); reason != Reason::kNone)
    return Reject(out, reason, detail);
  out.verdict = out.delta_rotation_deg <= v.verify_rotation_deg &&
                        out.delta_translation_m <= v.verify_translation_m
                    ? CalibrationOutcome::Verdict::kVerified
                    : CalibrationOutcome::Verdict::kUpdated;
  out.detail = out.verdict == CalibrationOutcome::Verdict::kVerified
                   ? "the prior calibration is confirmed"
                   : "the extrinsic changed by " + FixedDecimal(out.delta_rotation_deg) +
                         " deg / " + FixedDecimal(out.delta_translation_m) + " m";
  if (q.camera_scale_corrected != 0.0)
    out.detail += "; the camera's board distances were " +
                  FixedDecimal(std::fabs(q.camera_scale_corrected) * 100.0, 2) + " % " +
                  (q.camera_scale_corrected > 0.0 ? "longer" : "shorter") +
                  " than the LiDAR's and were corrected: measure the printed tag (or checkerboard "
                  "square) and check the camera's focal length";
  return out;
}

}  // namespace

RangeImage SessionProjection(const LidarModel& model) {
  RangeImage projection;
  // Only the grid is used (CellOf, rows): any range limits do, and no point map.
  projection.Configure(model, 0.5, 200.0, 1);
  return projection;
}

CalibrationOutcome Calibrate(const CalibConfig& config, const SessionObservations& observed,
                             const RangeImage& projection, const EngineConfig& engine,
                             ObservationSet* correspondences,
                             std::vector<double>* reprojection_px) {
  int out_of_order = 0, duplicates = 0;
  const std::vector<int> order = CaptureOrder(observed, &out_of_order, &duplicates);
  if (order.empty())
    return CalibrateInCaptureOrder(config, observed, projection, engine, correspondences,
                                   reprojection_px);
  std::vector<int> source_cluster;
  const SessionObservations ordered =
      SelectFrames(observed, order, std::vector<char>(observed.camera.size(), 1),
                   std::vector<char>(observed.lidar.size(), 1), &source_cluster);
  CalibrationOutcome out = CalibrateInCaptureOrder(config, ordered, projection, engine,
                                                   correspondences, reprojection_px);
  out.frames_out_of_order = out_of_order;
  out.duplicate_frames = duplicates;
  if (correspondences)
    for (BoardObservation& o : correspondences->observations) {
      o.frame = order[static_cast<size_t>(o.frame)];
      if (o.lidar_cluster >= 0)
        o.lidar_cluster = source_cluster[static_cast<size_t>(o.lidar_cluster)];
    }
  return out;
}

}  // namespace calibd
