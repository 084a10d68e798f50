#include "engine/engine_steps.hpp"

#include <algorithm>
#include <cmath>

#include "calibd/core/common/stats.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/verdict/camera_scale.hpp"
#include "calibd/core/verdict/measure_quality.hpp"

namespace calibd {

namespace {

// A correspondence is not its board's when, at the solution, the centroid of its LiDAR points
// lies outside the board's outline or farther from its plane than kFitSigmas range noise sigmas:
// the grid search paired the camera's board with furniture in its predicted region. The centroid,
// not each point: a far board's edge returns spill beyond its outline by a beam footprint.
constexpr double kFitSigmas = 3.0;
// Drop-and-solve rounds at most.
constexpr int kMaxDropRounds = 3;

// A LiDAR point is not its board's when, at the solution, it lies beyond the board's outline by
// more than this or by kFitSigmas range noise sigmas, whichever is larger: a return from the
// stand under the board or from a hand holding it, which the segmentation joined to the board's
// cluster (its range jump too small to part them). The box cost pulls the board towards such
// points in the board's plane and along its normal alike (behind it: the stand), by about
// a centimetre on a 16-ring LiDAR's few edge rows (docs/error-bound.md). Far beyond the
// solution's own error and a beam's footprint at the edge, and beyond the catalogue's
// configuration faults (a board 5 % smaller than configured sticks out by 2.3 cm at 0.9 m).
constexpr double kOffBoardMarginM = 0.05;
// At most this share of an observation's points is trimmed as off its board; beyond it the
// observation stays whole, for BoardsThatFit to judge.
constexpr double kMaxOffBoardShare = 0.5;

// Each observation's points in its board's frame with the extrinsic and board poses of
// `direct`, and the range noise sigma: the median over the boards of their points' RMS distance
// to their plane (most boards are right, a wrong one does not move the median).
struct PointsOnBoards {
  std::vector<Eigen::Vector3d> q;  ///< per point of the set, in its board's frame
  double noise_sigma_m = 0.0;
};

PointsOnBoards InBoardFrames(const ObservationSet& set, const DirectResult& direct) {
  PointsOnBoards out;
  out.q.resize(set.points.size(), Eigen::Vector3d::Zero());
  const size_t n = set.observations.size();
  std::vector<double> rms;
  for (size_t i = 0; i < n; ++i) {
    const BoardObservation& o = set.observations[i];
    if (o.num_points == 0) continue;
    const Pose T_board_lidar = direct.T_camera_board[i].inverse() * direct.T_camera_lidar;
    double sum = 0.0;
    for (int k = o.first_point; k < o.first_point + o.num_points; ++k) {
      const auto index = static_cast<size_t>(k);
      out.q[index] = T_board_lidar * set.points[index].cast<double>();
      sum += out.q[index].z() * out.q[index].z();
    }
    rms.push_back(std::sqrt(sum / o.num_points));
  }
  out.noise_sigma_m = std::max(rms.empty() ? 0.0 : Median(rms), 0.005);
  return out;
}

// Removes from `set` the points off their board (kOffBoardMarginM) at `direct`'s solution;
// returns how many.
int TrimPointsOffTheirBoards(const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                             ObservationSet* set) {
  if (direct.T_camera_board.size() != set->observations.size()) return 0;
  const PointsOnBoards on = InBoardFrames(*set, direct);
  const double margin = std::max(kOffBoardMarginM, kFitSigmas * on.noise_sigma_m);
  std::vector<char> keep(set->points.size(), 1);
  int trimmed = 0;
  for (const BoardObservation& o : set->observations) {
    const BoardGeometry& g = boards[static_cast<size_t>(o.board_index)];
    const auto first = static_cast<size_t>(o.first_point);
    const auto end = first + static_cast<size_t>(o.num_points);
    int off = 0;
    for (size_t k = first; k < end; ++k) {
      keep[k] = std::fabs(on.q[k].x()) <= 0.5 * g.width_m + margin &&
                std::fabs(on.q[k].y()) <= 0.5 * g.height_m + margin;
      off += !keep[k];
    }
    if (off > kMaxOffBoardShare * o.num_points) {
      std::fill(keep.begin() + first, keep.begin() + end, 1);
      continue;
    }
    trimmed += off;
  }
  return trimmed == 0 ? 0 : set->KeepPoints(keep);
}

// Per observation, whether its points' centroid fits its board (above) with the extrinsic and
// board poses of `direct`.
std::vector<char> BoardsThatFit(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                                const DirectResult& direct) {
  const size_t n = set.observations.size();
  std::vector<char> fits(n, 1);
  if (direct.T_camera_board.size() != n) return fits;
  const PointsOnBoards on = InBoardFrames(set, direct);
  std::vector<Eigen::Vector3d> centroid(n, Eigen::Vector3d::Zero());
  for (size_t i = 0; i < n; ++i) {
    const BoardObservation& o = set.observations[i];
    for (int k = o.first_point; k < o.first_point + o.num_points; ++k)
      centroid[i] += on.q[static_cast<size_t>(k)];
    if (o.num_points > 0) centroid[i] /= o.num_points;
  }
  const double max_z = kFitSigmas * on.noise_sigma_m;
  for (size_t i = 0; i < n; ++i) {
    const BoardGeometry& g = boards[static_cast<size_t>(set.observations[i].board_index)];
    const Eigen::Vector3d& c = centroid[i];
    fits[i] = std::fabs(c.z()) <= max_z && std::fabs(c.x()) <= 0.5 * g.width_m &&
              std::fabs(c.y()) <= 0.5 * g.height_m;
  }
  return fits;
}

// Drops from `set` the observations whose points do not fit their board (BoardsThatFit) at
// `direct`'s solution; returns how many.
int DropBoardsThatDoNotFit(const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                           ObservationSet* set) {
  return set->KeepOnly(BoardsThatFit(boards, *set, direct));
}

// The direct solve (paper §III-E) of one session with its corrections: each step updates
// `direct`, the boards and the correspondences in place.
class CorrectedSolve {
 public:
  CorrectedSolve(const EngineConfig& engine, const CameraModel& camera, const Pose& T_start,
                 ObservationSet* corr, QualityFigures* q, Solution* solution)
      : engine_(engine),
        camera_(camera),
        T_start_(T_start),
        corr_(*corr),
        q_(*q),
        boards_(solution->boards),
        direct_(solution->direct) {}

  // Solves from the start, board poses refined from the camera's (DirectSolveOptions).
  bool Solve() {
    direct_ = OptimizeDirect(boards_, corr_, T_start_, engine_.direct,
                             DirectSolveOptions::RefiningBoardPoses(camera_));
    return direct_.usable;
  }

  // Both corrections: the time offset first, then the camera's scale; false when a re-solve
  // failed.
  bool Correct() {
    std::vector<BoardDistance> distances = BoardDistances(corr_, direct_.T_camera_lidar, &boards_);
    if (CorrectTimeOffset(distances)) {
      if (!direct_.usable) return false;
      distances = BoardDistances(corr_, direct_.T_camera_lidar, &boards_);
    }
    return !(CorrectCameraScale(distances) && !direct_.usable);
  }

 private:
  // A camera running behind its stamps biases the solution along the boards' motion: its offset
  // is measured under the solution, the points moved to the camera's capture time, and solved
  // again (board_motion.hpp, EstimateTimeOffset).
  bool CorrectTimeOffset(const std::vector<BoardDistance>& distances) {
    const TimeOffsetEstimate t = EstimateTimeOffset(corr_, distances);
    if (!t.fitted || std::fabs(t.offset_s) <= kTimeOffsetSigmas * t.sigma_s) return false;
    ShiftToCaptureTime(corr_.time_offset_s + t.offset_s, direct_.T_camera_lidar, &corr_);
    Solve();
    return true;
  }

  // A tag printed at another size than configured (or a focal length off) scales every PnP
  // distance, which the translation would take up in proportion to the boards' distance: where
  // the boards' distances spread enough to measure it, the camera's patterns and distances are
  // scaled to the LiDAR's and the session solved again, as far as max_camera_scale_error
  // (beyond it the configuration is wrong, and the camera-scale gate refuses).
  bool CorrectCameraScale(const std::vector<BoardDistance>& distances) {
    const VerdictConfig& v = engine_.verdict;
    const CameraScaleEstimate e = EstimateCameraScale(corr_, distances);
    // Only a scale that would make the result wrong (kCorrectedScaleTolerances); once one
    // was corrected, what the second pass finds left of it counts beyond its sigma.
    const bool matters =
        q_.camera_scale_corrected != 0.0 ||
        std::fabs(e.scale) * e.distance_m > kCorrectedScaleTolerances * v.verify_translation_m;
    if (!e.scale_fitted || std::fabs(e.scale) <= kScaleSigmas * e.scale_sigma || !matters)
      return false;
    const double total = (1.0 + q_.camera_scale_corrected) * (1.0 + e.scale) - 1.0;
    if (std::fabs(total) > v.max_camera_scale_error) return false;
    ScaleCameraPatterns(1.0 / (1.0 + e.scale), &boards_, &corr_);
    q_.camera_scale_corrected = total;
    Solve();
    return true;
  }

  const EngineConfig& engine_;
  const CameraModel& camera_;
  const Pose& T_start_;
  ObservationSet& corr_;
  QualityFigures& q_;
  std::vector<BoardGeometry>& boards_;
  DirectResult& direct_;
};

// The indirect baseline: per-board fits, then PnP (indirect_optimizer.hpp); the direct cost only
// evaluated at its result, for the quality figures.
Reason SolveIndirect(const EngineConfig& engine, const CameraModel& camera, const Pose& T_start,
                     const ObservationSet& corr, Solution* solution, std::string* detail) {
  const IndirectResult ind =
      OptimizeIndirect(solution->boards, corr, camera, T_start, engine.indirect);
  if (!ind.usable) return Refuse(detail, Reason::kSolverFailed, "indirect method: " + ind.reason);
  solution->direct = OptimizeDirect(solution->boards, corr, ind.T_camera_lidar, engine.direct,
                                    DirectSolveOptions::EvaluateOnly());
  solution->direct.T_camera_lidar = ind.T_camera_lidar;
  return Reason::kNone;
}

}  // namespace

Reason Solve(const CalibConfig& config, const EngineConfig& engine, const CameraModel& camera,
             const Pose& T_start, ObservationSet* corr, QualityFigures* q, int* dropped_total,
             Solution* solution, std::string* detail) {
  solution->boards = config.boards;
  if (engine.method == EngineConfig::Method::kIndirect)
    return SolveIndirect(engine, camera, T_start, *corr, solution, detail);
  const DirectResult& direct = solution->direct;
  CorrectedSolve solve(engine, camera, T_start, corr, q, solution);
  // Both corrections once before dropping boards that do not fit (a large offset or scale
  // would make good boards look unfitting), and once after.
  if (!solve.Solve() || !solve.Correct())
    return Refuse(detail, Reason::kSolverFailed, direct.reason);
  // Points off their boards (the stands) pull the solution: trimmed, then solved again.
  solution->points_off_their_boards = TrimPointsOffTheirBoards(solution->boards, direct, corr);
  if (solution->points_off_their_boards > 0 && !solve.Solve())
    return Refuse(detail, Reason::kSolverFailed, direct.reason);
  // A board paired with a cluster that is not on it pulls the solution: dropped, then solved
  // again without it, until none is dropped (a pulled solution can hide some at first).
  for (int round = 0; round < kMaxDropRounds; ++round) {
    const int dropped = DropBoardsThatDoNotFit(solution->boards, direct, corr);
    if (dropped == 0) break;
    *dropped_total += dropped;
    CoverageFigures(config, *corr, q);
    const std::string after = " once " + std::to_string(*dropped_total) +
                              " whose LiDAR points did not lie on their board were dropped";
    if (const Reason reason = TooFewCorrespondences(*q, engine.verdict, after, detail);
        reason != Reason::kNone)
      return reason;
    if (!solve.Solve()) return Refuse(detail, Reason::kSolverFailed, direct.reason);
  }
  if (!solve.Correct()) return Refuse(detail, Reason::kSolverFailed, direct.reason);
  return Reason::kNone;
}

}  // namespace calibd
