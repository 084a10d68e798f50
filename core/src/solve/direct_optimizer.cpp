#include "calibd/core/solve/direct_optimizer.hpp"
#include "calibd/core/common/parallel_for.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/validation.hpp"

#include <ceres/ceres.h>

#include <Eigen/Cholesky>
#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <memory>
#include <optional>
#include <utility>

#include "calibd/core/solve/board_box_joint_cost.hpp"
#include "calibd/core/solve/board_pose_refinement.hpp"
#include "calibd/core/solve/compressed_box_cost.hpp"
#include "calibd/core/solve/corner_reprojection_cost.hpp"
#include "calibd/core/solve/pose_manifold.hpp"

namespace calibd {

namespace {

bool Used(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
          const std::vector<char>* use, size_t k) {
  const BoardObservation& o = set.observations[k];
  if (use != nullptr && (k >= use->size() || !(*use)[k])) return false;
  return o.board_index >= 0 && o.board_index < static_cast<int>(boards.size()) && o.num_points > 0;
}

int StrideOf(const BoardObservation& o, int max_points) {
  return std::max(1, (o.num_points + max_points - 1) / max_points);
}

// `config` with its per-observation point caps raised to the session's budget shared over the
// observations used (max_points_per_solve).
DirectOptimizerConfig WithSessionBudget(const std::vector<BoardGeometry>& boards,
                                        const ObservationSet& set, const std::vector<char>* use,
                                        DirectOptimizerConfig config) {
  int used = 0;
  for (size_t k = 0; k < set.observations.size(); ++k) used += Used(boards, set, use, k);
  if (used == 0) return config;
  config.max_points_per_observation =
      std::max(config.max_points_per_observation, config.max_points_per_solve / used);
  config.joint_points_per_observation =
      std::max(config.joint_points_per_observation, config.max_joint_points_per_solve / used);
  return config;
}

ceres::Solver::Options SolverOptions(const DirectOptimizerConfig& config) {
  ceres::Solver::Options options;
  options.max_num_iterations = config.max_iterations;
  options.function_tolerance = config.function_tolerance;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.num_threads = config.threads;
  options.logging_type = ceres::SILENT;
  return options;
}

// Board poses refined one by one with the extrinsic held fixed: each board's LiDAR points (box
// cost through T_camera_lidar) and its tag corners, a 6-unknown problem per board
// (board_pose_refinement.hpp). Boards [begin, end) of `set`; independent of the others, so ranges
// run on their own threads.
void RefineBoardPoses(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                      const std::vector<char>* use, const DirectOptimizerConfig& config,
                      const CameraModel& camera, const Pose& T_camera_lidar, size_t begin,
                      size_t end, std::vector<Pose>* T_camera_board) {
  constexpr int kMaxIterations = 20;
  constexpr double kFunctionTolerance = 1e-8;
  const double weight = config.lidar_sigma_m / config.corner_sigma_px;  // m per px
  const double scale = camera.intrinsics().fx * weight;
  double ext[7];  // held constant
  PoseToParameters(T_camera_lidar, ext);
  for (size_t k = begin; k < end; ++k) {
    if (!Used(boards, set, use, k)) continue;
    const BoardObservation& o = set.observations[k];
    const BoardGeometry& g = boards[o.board_index];
    const BoardBoxJointCost box(set.points.data() + o.first_point, o.num_points,
                                StrideOf(o, config.joint_points_per_observation), g.width_m / 2.0,
                                g.height_m / 2.0, config.alpha_m, config.huber_m);
    BoardPoseTerms terms;
    terms.box = &box;
    terms.T_camera_lidar = ext;
    terms.corner_huber = config.corner_huber_px * weight;
    std::array<std::optional<CornerReprojectionCost>, 4> corners;
    const auto tag_corners = g.TagCornersInBoard();
    for (int c = 0; c < 4; ++c) {
      Eigen::Vector2d xy;
      if (!camera.Unproject(o.corners_px[c], &xy)) continue;
      corners[static_cast<size_t>(c)].emplace(tag_corners[c], xy, scale);
      terms.corners[static_cast<size_t>(terms.num_corners++)] = &*corners[static_cast<size_t>(c)];
    }
    RefineBoardPose(terms, kMaxIterations, kFunctionTolerance, &(*T_camera_board)[k]);
  }
}

}  // namespace

bool DirectOptimizerConfig::IsValid(std::string* error) const {
  if (!(alpha_m >= 0.0 && alpha_m < 1.0)) return Invalid(error, "alpha_m must be in [0, 1) m");
  if (!(huber_m < 1.0)) return Invalid(error, "huber_m must be below 1 m");
  if (max_points_per_observation < 3)
    return Invalid(error, "max_points_per_observation must be >= 3");
  if (joint_points_per_observation < 3)
    return Invalid(error, "joint_points_per_observation must be >= 3");
  if (max_points_per_solve < 0) return Invalid(error, "max_points_per_solve must be >= 0");
  if (max_joint_points_per_solve < 0)
    return Invalid(error, "max_joint_points_per_solve must be >= 0");
  if (max_iterations < 1) return Invalid(error, "max_iterations must be >= 1");
  if (round_iterations < 1) return Invalid(error, "round_iterations must be >= 1");
  if (covariance_stretches < 2) return Invalid(error, "covariance_stretches must be >= 2");
  if (threads < 1) return Invalid(error, "threads must be >= 1");
  if (!(corner_sigma_px > 0.0 && corner_sigma_px < 100.0))
    return Invalid(error, "corner_sigma_px must be in (0, 100) px");
  if (!(lidar_sigma_m > 0.0 && lidar_sigma_m < 1.0))
    return Invalid(error, "lidar_sigma_m must be in (0, 1) m");
  if (!FiniteAbove(corner_huber_px, 0.0)) return Invalid(error, "corner_huber_px must be > 0");
  return true;
}

// The box cost's terms of the observations `use` selects, at most `points_per_observation`
// points each (a stride through the rest), with the given board poses; counts the observations
// and points into `result`.
std::vector<BoxTerm> BoxTerms(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                              const std::vector<char>* use, const DirectOptimizerConfig& config,
                              int points_per_observation, const std::vector<Pose>& T_camera_board,
                              std::vector<size_t>* term_observation, DirectResult* result) {
  std::vector<BoxTerm> terms;
  for (size_t k = 0; k < set.observations.size(); ++k) {
    if (!Used(boards, set, use, k)) continue;
    const BoardObservation& o = set.observations[k];
    const BoardGeometry& g = boards[o.board_index];
    BoxTerm term;
    term.points = set.points.data() + o.first_point;
    term.num_points = o.num_points;
    term.stride = StrideOf(o, points_per_observation);
    term.T_board_camera = T_camera_board[k].inverse();
    term.half_extent = Eigen::Vector3d(g.width_m / 2.0, g.height_m / 2.0, config.alpha_m);
    terms.push_back(term);
    term_observation->push_back(k);
    ++result->observations;
    result->points += term.num_used();
  }
  return terms;
}

// What a solve with the board poses held is for.
enum class HeldSolve {
  kStart,     ///< to convergence before the first board-pose refinement, half the points
  kRound,     ///< a few steps between board-pose refinements, half the points
  kFinal,     ///< to convergence, then residual statistics and information
  kEvaluate,  ///< no solve: residual statistics and information at the start pose
  kResolve,   ///< to convergence, no statistics (stability re-solves)
};

// Paper Eq. 4 with the board poses held: solves (or, for kEvaluate, only evaluates)
// T_camera_lidar from `T_start` and fills `result` with the solution and, for kFinal and
// kEvaluate, the residual statistics and the information.
void SolveWithBoardPoses(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                         const std::vector<char>* use, const DirectOptimizerConfig& config,
                         const std::vector<Pose>& T_camera_board, const Pose& T_start,
                         HeldSolve mode, DirectResult* out) {
  DirectResult& result = *out;
  result.T_camera_lidar = T_start;
  result.observations = result.points = 0;
  result.information.setZero();
  result.plane_information.setZero();
  double params[7];
  PoseToParameters(T_start, params);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddParameterBlock(params, 7, new PoseManifold);

  // A solve between board-pose refinements only steers the alternation: half the points do.
  const bool statistics = mode == HeldSolve::kFinal || mode == HeldSolve::kEvaluate;
  const bool steering = mode == HeldSolve::kStart || mode == HeldSolve::kRound;
  const int points_per_observation = steering ? std::max(3, config.max_points_per_observation / 2)
                                              : config.max_points_per_observation;
  // The observations' box costs in compressed form (compressed_box_cost.hpp), a few chunks so
  // that Ceres evaluates them on its threads.
  std::vector<size_t> term_observation;  // each term's observation in `set`
  const std::vector<BoxTerm> terms = BoxTerms(boards, set, use, config, points_per_observation,
                                              T_camera_board, &term_observation, &result);
  const size_t chunks = std::min(terms.size(), static_cast<size_t>(4 * config.threads));
  std::vector<const CompressedBoxCost*> costs;
  for (size_t c = 0; c < chunks; ++c) {
    auto* cost = new CompressedBoxCost(
        std::vector<BoxTerm>(terms.begin() + static_cast<long>(terms.size() * c / chunks),
                             terms.begin() + static_cast<long>(terms.size() * (c + 1) / chunks)),
        config.huber_m);
    problem.AddResidualBlock(cost, nullptr, params);
    costs.push_back(cost);
  }

  ceres::Solver::Options options = SolverOptions(config);
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // 6 unknowns, 7 rows per chunk
  // and a few steps towards the joint optimum; the final solve converges fully.
  if (mode == HeldSolve::kRound) options.max_num_iterations = config.round_iterations;
  if (mode != HeldSolve::kEvaluate) {
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    if (result.iterations == 0) result.initial_cost = summary.initial_cost;
    result.iterations += static_cast<int>(summary.iterations.size());
    result.final_cost = summary.final_cost;
    result.T_camera_lidar = PoseFromParameters(params);
    result.usable =
        summary.IsSolutionUsable() && (summary.termination_type == ceres::CONVERGENCE || steering);
    if (!result.usable) result.reason = "solver: " + summary.message;
  } else {
    result.usable = true;
  }

  if (!statistics) return;
  // Residual statistics without the robust loss, and J^T J in the tangent space.
  BoxStatistics stats;
  for (const CompressedBoxCost* c : costs) c->Statistics(result.T_camera_lidar, &stats);
  result.residual_rms_m = std::sqrt(stats.sum_squared_residuals / std::max(1, stats.points));
  result.information = stats.information;
  result.plane_information = stats.plane_information;
  result.min_information_eigenvalue =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(result.information)
          .eigenvalues()(0);
  std::vector<ObservationScore> scores(terms.size());
  for (size_t i = 0; i < terms.size(); ++i) {
    const BoardObservation& o = set.observations[term_observation[i]];
    scores[i].board = o.board_index;
    scores[i].frame = o.frame;
    scores[i].score = stats.term_scores[i];
  }
  result.clustered =
      ClusterRobustCovariance(result.information, scores, config.covariance_stretches);
}

// The checks both entry points make before solving; false with result->reason set.
static bool CanSolve(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                     const DirectOptimizerConfig& config, const std::vector<char>* use,
                     DirectResult* result) {
  std::string why;
  if (!config.IsValid(&why)) {
    result->reason = "config: " + why;
    return false;
  }
  bool any = false;
  for (size_t k = 0; k < set.observations.size() && !any; ++k) any = Used(boards, set, use, k);
  if (!any) result->reason = "no board observations with LiDAR points";
  return any;
}

DirectResult OptimizeDirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                            const Pose& T_init, const DirectOptimizerConfig& session_config,
                            const DirectSolveOptions& options) {
  const std::vector<char>* use = options.use;
  const auto t0 = std::chrono::steady_clock::now();
  DirectResult result;
  result.T_camera_lidar = T_init;
  if (!CanSolve(boards, set, session_config, use, &result)) return result;
  const DirectOptimizerConfig config = WithSessionBudget(boards, set, use, session_config);

  // Board poses: the camera's, or refined with the extrinsic (refine_board_poses).
  std::vector<Pose> T_camera_board(set.observations.size());
  for (size_t k = 0; k < set.observations.size(); ++k)
    T_camera_board[k] = set.observations[k].T_camera_board;
  Pose T_start = T_init;
  const bool joint = options.solve && config.refine_board_poses && options.camera != nullptr;
  if (joint) {
    // Alternation: extrinsic with the board poses held, then each board's pose with the
    // extrinsic held; the final solve below starts from the last extrinsic. The first extrinsic
    // solve runs to convergence: board poses refined against an extrinsic still degrees off
    // (a grid search's step at close range) move to fit it, and the alternation then settles in
    // a minimum beside the right one.
    for (int round = 0; round < config.refine_rounds; ++round) {
      SolveWithBoardPoses(boards, set, use, config, T_camera_board, T_start,
                          round == 0 ? HeldSolve::kStart : HeldSolve::kRound, &result);
      if (!result.usable) return result;
      T_start = result.T_camera_lidar;
      // One slice of the observations a thread: each writes its own boards' poses.
      const size_t n = set.observations.size();
      const int threads = std::max(1, std::min(config.threads, 8));
      ParallelFor(threads, threads, [&](int, int t) {
        const auto slice = [&](int k) { return n * static_cast<size_t>(k) / threads; };
        RefineBoardPoses(boards, set, use, config, *options.camera, T_start, slice(t), slice(t + 1),
                         &T_camera_board);
      });
    }
    for (size_t k = 0; k < set.observations.size(); ++k) {
      if (!Used(boards, set, use, k)) continue;
      ++result.refined_boards;
      result.board_rotation_change_deg +=
          RotationAngle(T_camera_board[k].linear(), set.observations[k].T_camera_board.linear()) *
          kRad2Deg;
      result.board_translation_change_m +=
          (T_camera_board[k].translation() - set.observations[k].T_camera_board.translation())
              .norm();
    }
    result.board_rotation_change_deg /= std::max(1, result.refined_boards);
    result.board_translation_change_m /= std::max(1, result.refined_boards);
  }
  SolveWithBoardPoses(boards, set, use, config, T_camera_board, T_start,
                      options.solve ? HeldSolve::kFinal : HeldSolve::kEvaluate, &result);
  result.T_camera_board = std::move(T_camera_board);
  result.solve_ms = MsSince(t0);
  return result;
}

DirectResult ResolveWithHeldBoards(const std::vector<BoardGeometry>& boards,
                                   const ObservationSet& set, const Pose& T_init,
                                   const DirectOptimizerConfig& session_config,
                                   const std::vector<Pose>& T_camera_board,
                                   const std::vector<char>* use) {
  const auto t0 = std::chrono::steady_clock::now();
  DirectResult result;
  result.T_camera_lidar = T_init;
  if (T_camera_board.size() != set.observations.size()) {
    result.reason = "one board pose per observation needed";
    return result;
  }
  if (!CanSolve(boards, set, session_config, use, &result)) return result;
  const DirectOptimizerConfig config = WithSessionBudget(boards, set, use, session_config);
  SolveWithBoardPoses(boards, set, use, config, T_camera_board, T_init, HeldSolve::kResolve,
                      &result);
  result.solve_ms = MsSince(t0);
  return result;
}

DirectOptimizerConfig ReSolveSettings(const DirectOptimizerConfig& solver) {
  DirectOptimizerConfig one = solver;
  one.threads = 1;
  one.max_points_per_observation = std::max(3, one.max_points_per_observation / 2);
  one.max_points_per_solve /= 2;
  return one;
}

std::vector<Pose> HeldBoardPoses(const ObservationSet& set, const DirectResult& direct) {
  const size_t n = set.observations.size();
  if (direct.T_camera_board.size() == n) return direct.T_camera_board;
  std::vector<Pose> held(n);
  for (size_t k = 0; k < n; ++k) held[k] = set.observations[k].T_camera_board;
  return held;
}

bool SolveHeldBoardsByGaussNewton(const std::vector<BoardGeometry>& boards,
                                  const ObservationSet& set, const Pose& T_start,
                                  const DirectOptimizerConfig& session_config,
                                  const std::vector<Pose>& T_camera_board, Pose* T_camera_lidar) {
  // The steps shrink geometrically once the points crossing the boards' edges settle (by about
  // 0.6 a step at worst): the solve ends where a step, translation and rotation each, is below
  // kSettled of how far it has moved (the rest, about 1.5 steps, 1.5 % of the move at most: a
  // response known to that is all an error bound needs) or below kConverged (m, rad).
  constexpr double kSettled = 1e-2;
  constexpr double kConverged = 1e-6;
  constexpr int kMaxSteps = 16;
  DirectResult counts;
  if (T_camera_board.size() != set.observations.size() ||
      !CanSolve(boards, set, session_config, nullptr, &counts))
    return false;
  const DirectOptimizerConfig config = WithSessionBudget(boards, set, nullptr, session_config);
  std::vector<size_t> term_observation;
  const CompressedBoxCost cost(
      BoxTerms(boards, set, nullptr, config, config.max_points_per_observation, T_camera_board,
               &term_observation, &counts),
      config.huber_m);
  Pose T = T_start;
  for (int k = 0; k < kMaxSteps; ++k) {
    double x[7];
    PoseToParameters(T, x);
    Eigen::Matrix<double, 6, 6> H;
    Eigen::Matrix<double, 6, 1> g;
    double rtr = 0.0;
    cost.NormalEquations(x, &H, &g, &rtr);
    const Eigen::LLT<Eigen::Matrix<double, 6, 6>> llt(H);
    if (llt.info() != Eigen::Success) return false;
    const Eigen::Matrix<double, 6, 1> step = -llt.solve(g);
    if (!step.allFinite()) return false;
    T = PoseMovedBy(T, step);
    const Eigen::Matrix<double, 6, 1> moved = PoseTangent(T_start, T);
    const auto settled = [&](int part) {
      const double size = step.segment<3>(part).norm();
      return size < kConverged || size < kSettled * moved.segment<3>(part).norm();
    };
    if (settled(0) && settled(3)) {
      *T_camera_lidar = T;
      return true;
    }
  }
  return false;
}

}  // namespace calibd
