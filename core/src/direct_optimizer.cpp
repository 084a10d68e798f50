#include "calibd/core/direct_optimizer.hpp"

#include <ceres/ceres.h>

#include <Eigen/Eigenvalues>
#include <chrono>
#include <cmath>
#include <memory>

#include "calibd/core/box_cost.hpp"
#include "calibd/core/pose_manifold.hpp"

namespace calibd {

bool DirectOptimizerConfig::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(alpha_m >= 0.0 && alpha_m < 1.0)) return fail("alpha_m must be in [0, 1) m");
  if (!(huber_m < 1.0)) return fail("huber_m must be below 1 m");
  if (max_points_per_observation < 3) return fail("max_points_per_observation must be >= 3");
  if (max_iterations < 1) return fail("max_iterations must be >= 1");
  if (threads < 1) return fail("threads must be >= 1");
  return true;
}

DirectResult OptimizeDirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                            const Pose& T_init, const DirectOptimizerConfig& config,
                            const std::vector<char>* use, bool solve) {
  const auto t0 = std::chrono::steady_clock::now();
  DirectResult result;
  result.T_camera_lidar = T_init;
  std::string why;
  if (!config.IsValid(&why)) {
    result.reason = "config: " + why;
    return result;
  }

  double params[7];
  PoseToParameters(T_init, params);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  problem_options.cost_function_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddParameterBlock(params, 7, new PoseManifold);

  std::vector<const BoardBoxCost*> costs;
  for (size_t k = 0; k < set.observations.size(); ++k) {
    const BoardObservation& o = set.observations[k];
    if (use != nullptr && (k >= use->size() || !(*use)[k])) continue;
    if (o.board_index < 0 || o.board_index >= static_cast<int>(boards.size()) || o.num_points <= 0)
      continue;
    const BoardGeometry& g = boards[o.board_index];
    const int stride = std::max(1, (o.num_points + config.max_points_per_observation - 1) /
                                       config.max_points_per_observation);
    auto* cost = new BoardBoxCost(set.points.data() + o.first_point, o.num_points, stride,
                                  o.T_camera_board.inverse(), g.width_m / 2.0, g.height_m / 2.0,
                                  config.alpha_m, config.huber_m);
    problem.AddResidualBlock(cost, nullptr, params);
    costs.push_back(cost);
    ++result.observations;
    result.points += cost->num_used_points();
  }
  if (result.observations == 0) {
    result.reason = "no board observations with LiDAR points";
    return result;
  }

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;  // 6 unknowns, many residuals
  options.max_num_iterations = config.max_iterations;
  options.function_tolerance = config.function_tolerance;
  options.gradient_tolerance = 1e-12;
  options.parameter_tolerance = 1e-12;
  options.num_threads = config.threads;
  options.logging_type = ceres::SILENT;
  if (solve) {
    ceres::Solver::Summary summary;
    ceres::Solve(options, &problem, &summary);
    result.iterations = static_cast<int>(summary.iterations.size());
    result.initial_cost = summary.initial_cost;
    result.final_cost = summary.final_cost;
    result.T_camera_lidar = PoseFromParameters(params);
    result.usable = summary.IsSolutionUsable() && summary.termination_type == ceres::CONVERGENCE;
    if (!result.usable) result.reason = "solver: " + summary.message;
  } else {
    result.usable = true;
  }

  // Residual statistics without the robust loss, and J^T J in the tangent space.
  double sum_sq = 0.0;
  for (const BoardBoxCost* c : costs)
    for (int i = 0; i < c->num_used_points(); ++i)
      sum_sq += c->PointResidual(result.T_camera_lidar, i).squaredNorm();
  result.residual_rms_m = std::sqrt(sum_sq / std::max(1, result.points));
  ceres::CRSMatrix jacobian;
  problem.Evaluate(ceres::Problem::EvaluateOptions(), nullptr, nullptr, nullptr, &jacobian);
  for (int row = 0; row < jacobian.num_rows; ++row) {
    Eigen::Matrix<double, 1, 6> j = Eigen::Matrix<double, 1, 6>::Zero();
    for (int k = jacobian.rows[row]; k < jacobian.rows[row + 1]; ++k)
      j[jacobian.cols[k]] = jacobian.values[k];
    result.information.noalias() += j.transpose() * j;
    // Every residual block holds (x, y, z) triples, so row % 3 == 2 is a board-plane row.
    if (row % 3 == 2) result.plane_information.noalias() += j.transpose() * j;
  }
  result.min_information_eigenvalue =
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>>(result.information)
          .eigenvalues()(0);
  result.solve_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  return result;
}

}  // namespace calibd
