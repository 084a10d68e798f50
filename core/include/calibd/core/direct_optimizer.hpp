#pragma once
/// \file
/// Direct optimisation of T_camera_lidar over raw LiDAR board points (paper §III-E, Eq. 4-5):
/// every board observation's points are moved into its board frame through the camera's
/// T_board_camera and the candidate extrinsic, and the box cost (box_cost.hpp) is minimised with
/// Ceres over SE(3). No per-board vertex fit, so sparse or partial clusters still constrain it.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibd/core/board.hpp"
#include "calibd/core/board_observation.hpp"
#include "calibd/core/geometry.hpp"

namespace calibd {

struct DirectOptimizerConfig {
  double alpha_m = 0.0;   ///< half-thickness allowance along the board normal (paper: 0 best)
  double huber_m = 0.05;  ///< Huber threshold on a point's residual norm; <= 0 disables it
  int max_points_per_observation = 256;  ///< larger clusters are strided down to about this
  int max_iterations = 50;
  double function_tolerance = 1e-10;
  int threads = 2;

  bool IsValid(std::string* error) const;
};

struct DirectResult {
  bool usable = false;  ///< Ceres judged the solution usable and it converged
  std::string reason;   ///< why not, when !usable
  Pose T_camera_lidar = Pose::Identity();
  int iterations = 0;
  int observations = 0;
  int points = 0;  ///< points used (after striding)
  double initial_cost = 0.0, final_cost = 0.0;
  double residual_rms_m = 0.0;  ///< RMS of the point residual norms (no robust loss)
  /// J^T J at the solution in the tangent space [dt, dtheta] (left perturbation): observability.
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double min_information_eigenvalue = 0.0;
  /// The same from the board-plane rows alone (each point's distance to its board plane, the z
  /// term of Eq. 3). Edges constrain in-plane directions only through the few points at a
  /// board's border, which beam width and mixed points make unreliable, so observability is
  /// judged on this one: one board, or parallel boards, leave it rank-deficient.
  Eigen::Matrix<double, 6, 6> plane_information = Eigen::Matrix<double, 6, 6>::Zero();
  double solve_ms = 0.0;
};

/// Minimises paper Eq. 4 starting from `T_camera_lidar_init`. `boards[o.board_index]` gives each
/// observation's board size. `use` (optional, one entry per observation) selects a subset.
/// With `solve` false it only evaluates residuals and information at the initial pose.
DirectResult OptimizeDirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                            const Pose& T_camera_lidar_init, const DirectOptimizerConfig& config,
                            const std::vector<char>* use = nullptr, bool solve = true);

}  // namespace calibd
