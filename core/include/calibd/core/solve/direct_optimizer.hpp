#pragma once
/// \file
/// Direct optimisation of T_camera_lidar over raw LiDAR board points (paper §III-E, Eq. 4-5):
/// every board observation's points are moved into its board frame through the camera's
/// T_board_camera and the candidate extrinsic, and the box cost (box_cost.hpp) is minimised with
/// Ceres over SE(3). No per-board vertex fit, so sparse or partial clusters still constrain it.

#include <Eigen/Core>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/session/board_observation.hpp"
#include "calibd/core/solve/clustered_covariance.hpp"

namespace calibd {

struct DirectOptimizerConfig {
  double alpha_m = 0.0;  ///< half-thickness allowance along the board normal (paper: 0 best)
  /// Huber threshold on a point's residual norm, m; <= 0 disables it. About the LiDAR's range
  /// sigma: mixed ("ghost") returns at board edges then pull linearly, not quadratically
  /// (the gain over 0.05 m: docs/accuracy-and-speed.md, "Why the thresholds are where
  /// they are").
  double huber_m = 0.02;
  /// Larger clusters are strided down to about this many points; the solve's time is about
  /// proportional to it (calibd-bench pipeline). Fewer lost accuracy
  /// (DirectOptimizerTest.BoardPoseRefinementRemovesCameraPoseNoise).
  int max_points_per_observation = 256;
  /// The session's point budget: with fewer observations than a drive's, each gets up to
  /// this / observations points instead, so a dozen still poses of one board use every point
  /// they have (their information is in the points), while a 600-board drive is strided to
  /// max_points_per_observation as before. Same for joint_points_per_observation.
  int max_points_per_solve = 600 * 256;
  int max_joint_points_per_solve = 600 * 64;
  int max_iterations = 50;
  double function_tolerance = 1e-10;
  int threads = 2;
  /// Beyond the paper: Eq. 4 takes the camera's PnP board poses as exact, but a far board's
  /// PnP tilt is uncertain by degrees, and the LiDAR's plane of the same board knows better.
  /// With refinement, the extrinsic is solved with the board poses held (to convergence, from a
  /// start that may be degrees off), then every board's pose is refined with the extrinsic held,
  /// from its tag corners (CornerReprojectionCost) and its LiDAR points (BoardBoxJointCost) weighed
  /// by their noise, refine_rounds times; then the extrinsic is solved once more (an alternation:
  /// a joint solve of all poses by Schur complement reached the same accuracy more slowly). Its
  /// effect on accuracy: `calibd-bench calib`, Table II's "direct with board-pose refinement"
  /// (docs/accuracy-and-speed.md). Needs the camera model
  /// (DirectSolveOptions::RefiningBoardPoses).
  bool refine_board_poses = true;
  double corner_sigma_px = 0.25;  ///< tag corner noise (1 sigma) that weighs the camera's term
  double lidar_sigma_m = 0.02;    ///< LiDAR range noise (1 sigma) that weighs the LiDAR's term
  double corner_huber_px = 2.0;   ///< Huber threshold on a corner's reprojection error
  /// LiDAR points per board in its pose refinement (strided like max_points_per_observation):
  /// a board's pose needs its plane, not every point.
  int joint_points_per_observation = 64;
  /// Extrinsic / board-pose alternations before the final solve: the alternation converges
  /// slowly towards the joint optimum; each round costs about a third of the solve time.
  int refine_rounds = 2;
  /// Iterations of each extrinsic solve between refinements (the final solve runs to
  /// convergence, up to max_iterations).
  int round_iterations = 4;
  /// Runs of consecutive frames the cluster-robust covariance clusters by
  /// (clustered_covariance.hpp): each a stretch of a drive or a few still poses, long enough to
  /// hold what neighbouring frames share, and enough of them for the covariance to be estimated.
  int covariance_stretches = 8;

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
  /// The extrinsic's covariance robust to errors shared by a board or a stretch of frames
  /// (clustered_covariance.hpp), tangent [dt, dtheta]; with the information, from the final solve.
  ClusteredCovariance clustered;
  double solve_ms = 0.0;
  int refined_boards = 0;  ///< board poses refined (0 without refine_board_poses)
  /// Mean change of the refined board poses from the camera's PnP: rotation (deg), translation
  /// (m).
  double board_rotation_change_deg = 0.0, board_translation_change_m = 0.0;
  /// The board poses the final solve held, one per observation of the set: the camera's PnP
  /// poses, or the refined ones (OptimizeDirect only; empty when it failed early).
  std::vector<Pose> T_camera_board;
};

/// What one OptimizeDirect call does beyond solving on every observation with the camera's board
/// poses held. The named constructors read at the call site.
struct DirectSolveOptions {
  /// One entry per observation of the set, non-zero for those to use; null: all of them.
  const std::vector<char>* use = nullptr;
  /// False: only the residuals and information at the initial pose, no solve.
  bool solve = true;
  /// With config.refine_board_poses: the camera whose corners refine the board poses jointly
  /// with the extrinsic. Null: the camera's PnP poses are held.
  const CameraModel* camera = nullptr;

  static DirectSolveOptions EvaluateOnly() {
    DirectSolveOptions o;
    o.solve = false;
    return o;
  }
  static DirectSolveOptions RefiningBoardPoses(const CameraModel& camera) {
    DirectSolveOptions o;
    o.camera = &camera;
    return o;
  }
};

/// Minimises paper Eq. 4 starting from `T_camera_lidar_init`. `boards[o.board_index]` gives each
/// observation's board size. With board poses refined (`options.camera`), `information` and the
/// residuals are those of the extrinsic with the refined board poses held fixed.
DirectResult OptimizeDirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                            const Pose& T_camera_lidar_init, const DirectOptimizerConfig& config,
                            const DirectSolveOptions& options = {});

/// Re-solves T_camera_lidar from `T_init` on the observations selected by `use`, with the given
/// board poses (one per observation, e.g. a previous OptimizeDirect's T_camera_board) held and no
/// refinement: the stability re-solves on parts of the data. No residual statistics or
/// information are computed.
DirectResult ResolveWithHeldBoards(const std::vector<BoardGeometry>& boards,
                                   const ObservationSet& set, const Pose& T_init,
                                   const DirectOptimizerConfig& config,
                                   const std::vector<Pose>& T_camera_board,
                                   const std::vector<char>* use);

/// Paper Eq. 4 with the given board poses held (one per observation), solved from `T_start` by
/// plain Gauss-Newton steps on the box cost's normal equations (compressed_box_cost.hpp) over the
/// points `config` takes, on one thread: what a re-solve of the same data converges to, in about
/// half the evaluations of ResolveWithHeldBoards' trust region when the start lies close (a
/// quality check's small shift of the data). No residual statistics. False where H is singular
/// or the steps have not settled (each below a hundredth of the distance moved) within 16.
bool SolveHeldBoardsByGaussNewton(const std::vector<BoardGeometry>& boards,
                                  const ObservationSet& set, const Pose& T_start,
                                  const DirectOptimizerConfig& config,
                                  const std::vector<Pose>& T_camera_board, Pose* T_camera_lidar);

/// The solver's settings for one re-solve of a quality check, on one thread: the spread or the
/// response of the extrinsic, not every point of each board: half the points do (half of
/// max_points_per_observation and of max_points_per_solve, at least 3 a board).
DirectOptimizerConfig ReSolveSettings(const DirectOptimizerConfig& solver);

/// The board poses a re-solve of `direct` holds, one per observation of `set`: the solve's
/// refined ones, or the camera's where it refined none.
std::vector<Pose> HeldBoardPoses(const ObservationSet& set, const DirectResult& direct);

}  // namespace calibd
