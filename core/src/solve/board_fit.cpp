#include "calibd/core/solve/board_fit.hpp"

#include <ceres/ceres.h>

#include <cmath>

#include "calibd/core/solve/compressed_box_cost.hpp"
#include "calibd/core/solve/pose_manifold.hpp"
#include "solve/box_hinge.hpp"

namespace calibd {

BoardFitResult FitBoardPose(const Eigen::Vector3f* points, int num_points, double half_width,
                            double half_height, double alpha, double huber_m,
                            const Pose& T_lidar_board_init, int max_iterations,
                            double function_tolerance, double parameter_tolerance) {
  BoardFitResult result;
  result.T_lidar_board = T_lidar_board_init;
  if (num_points < 3) {
    result.reason = "fewer than 3 points";
    return result;
  }
  // The box cost maps p_B = T_board_camera * T * p; with T_board_camera = I its parameter T is
  // T_board_lidar directly (Eq. 2).
  double params[7];
  PoseToParameters(T_lidar_board_init.inverse(), params);
  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  problem.AddParameterBlock(params, 7, new PoseManifold);
  // One term in the compressed form (compressed_box_cost.hpp): Ceres takes the same steps as
  // with a row per point, from a 7 x 7 Jacobian instead of thousands of rows.
  BoxTerm term;
  term.points = points;
  term.num_points = num_points;
  term.half_extent = Eigen::Vector3d(half_width, half_height, alpha);
  problem.AddResidualBlock(new CompressedBoxCost({term}, huber_m), nullptr, params);
  ceres::Solver::Options options;
  // 6 unknowns: the normal equations.
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = max_iterations;
  options.function_tolerance = function_tolerance;
  options.parameter_tolerance = parameter_tolerance;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  const Pose T_board_lidar = PoseFromParameters(params);
  result.T_lidar_board = T_board_lidar.inverse();
  result.iterations = static_cast<int>(summary.iterations.size());
  result.usable = summary.IsSolutionUsable();
  if (!result.usable) result.reason = "solver: " + summary.message;
  double sum_sq = 0.0;
  for (int i = 0; i < num_points; ++i)
    sum_sq += detail::HingeResidual(T_board_lidar * points[i].cast<double>(), term.half_extent)
                  .squaredNorm();
  result.residual_rms_m = std::sqrt(sum_sq / num_points);
  return result;
}

}  // namespace calibd
