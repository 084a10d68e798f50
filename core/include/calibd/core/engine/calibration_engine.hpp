#pragma once
/// \file
/// The session-level calibration, the pipeline's steps in order (calibration_engine.cpp): static
/// scenery out, coarse grid search (paper §III-D), motion compensation, direct optimisation
/// (§III-E, or the indirect baseline) with its corrections, quality figures, and the verdict's
/// gates against the prior calibration (verdict/verdict.hpp).

#include <limits>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/core/session/static_scenery.hpp"
#include "calibd/core/solve/direct_optimizer.hpp"
#include "calibd/core/solve/grid_search.hpp"
#include "calibd/core/solve/indirect_optimizer.hpp"
#include "calibd/core/verdict/camera_scale.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"
#include "calibd/core/verdict/quality_figures.hpp"
#include "calibd/core/verdict/reason.hpp"
#include "calibd/core/verdict/reprojection.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

struct EngineConfig {
  enum class Method { kDirect, kIndirect } method = Method::kDirect;
  GridSearchConfig grid;
  StaticSceneryConfig scenery;      ///< LiDAR clusters dropped before the grid search
  MotionCompensationConfig motion;  ///< applied to the correspondences after the grid search
  DirectOptimizerConfig direct;
  IndirectOptimizerConfig indirect;
  VerdictConfig verdict;
  int stability_runs = 4;  ///< re-solves on random halves of the correspondences (0: skip)
  /// Solves of all correspondences from starts kStartCheckRotationDeg / kStartCheckTranslationM
  /// (calibration_engine.cpp) off the solution, with the board poses from the camera again: the
  /// half-data re-solves start from the solution and cannot see that the solve ended in a
  /// minimum beside the right one (0: skip).
  int start_checks = 1;
  /// The solve uses the correspondences of at most this many frame pairs, spread evenly over the
  /// session (0: all). Bounds the solve's time and memory whatever the session's length: a
  /// 2000-pair session solves like a 200-pair one drawn from all of it (motion compensation
  /// still sees every frame).
  int max_solve_frames = 200;
};

/// Share of the LiDAR's points (SessionObservations::lidar_outside_points) beyond which the
/// configured model is not the one that recorded them. A model's field of view holds its own
/// sensor's points (the catalogue's are datasheet figures with a margin); an OT128's clouds under
/// a Mid-360's model (-7 to 52 deg) leave a third of them out, and the detector then segments
/// what is left on the wrong grid.
inline constexpr double kMaxLidarOutsideShare = 0.1;

struct CalibrationOutcome {
  enum class Verdict { kVerified, kUpdated, kRejected } verdict = Verdict::kRejected;
  Reason reason = Reason::kNone;  ///< kNone unless rejected
  std::string detail;             ///< human-readable explanation with the figures involved
  Pose prior_T_camera_lidar = Pose::Identity();
  Pose T_camera_lidar = Pose::Identity();  ///< the estimate (even when rejected, for diagnosis)
  /// True once the optimiser produced T_camera_lidar: a rejection by a later gate (observability,
  /// stability, reprojection, residual, delta) still carries the solved estimate; before that
  /// T_camera_lidar is only the prior or the grid search's candidate.
  bool solved = false;
  double delta_rotation_deg = 0.0, delta_translation_m = 0.0;
  QualityFigures quality;
  int static_scenery_clusters = 0;  ///< LiDAR clusters dropped as static scenery
  /// Frame pairs that arrived earlier than a pair captured before them, and pairs that arrived
  /// again (the same capture times): the engine works on the pairs in capture order, each once.
  int frames_out_of_order = 0, duplicate_frames = 0;
  /// Correspondences dropped before the final solve: the grid search had paired the camera's
  /// board with a cluster whose points do not lie on that board at the solution (furniture in
  /// its predicted region). See DropBoardsThatDoNotFit in solve_session.cpp.
  int dropped_correspondences = 0;
  /// LiDAR points trimmed before the final solve as off their boards: beyond a board's outline
  /// at the solution by more than 5 cm (or three range noise sigmas), a stand's or a hand's that
  /// the segmentation joined to the board. See TrimPointsOffTheirBoards in solve_session.cpp.
  int points_off_their_boards = 0;
  GridSearchResult grid;
  MotionCompensationStats motion;
  /// Board-pose refinement (DirectOptimizerConfig::refine_board_poses): boards refined and the
  /// mean change of their poses from the camera's PnP, rotation (deg) and translation (m).
  int refined_boards = 0;
  double board_rotation_change_deg = 0.0, board_translation_change_m = 0.0;
  double optimise_ms = 0.0, quality_ms = 0.0;
};

const char* VerdictName(CalibrationOutcome::Verdict v);

/// The range image Calibrate's session-level steps map LiDAR directions into (the grid search's
/// windows, paper §III-D; the ring-elevation check's rows): `model`'s grid, for directions only
/// (it holds no sweep). It allocates: build it once, e.g. at start-up.
RangeImage SessionProjection(const LidarModel& model);

/// Runs the whole session-level calibration. `projection` is SessionProjection of the config's
/// LiDAR model. `correspondences` (optional) receives
/// the camera-LiDAR board pairs the grid search found (for pictures and reports), each naming
/// its cluster in `session.lidar` (BoardObservation::lidar_cluster).
/// `reprojection_px` (optional, for reports) receives the paper Table I error of each of those
/// correspondences, index for index: the mean over its tag corners (px) of the errors behind
/// QualityFigures::reprojection_mean_px, NaN where the board's fit failed; empty when the
/// calibration stopped before the solve. Without it nothing more is allocated, unless the frame
/// pairs are out of capture order or repeated (CalibrationOutcome::frames_out_of_order): the
/// engine then works on a copy in capture order, each pair once, and `correspondences` still name
/// the frames and clusters of `session`.
CalibrationOutcome Calibrate(const CalibConfig& config, const SessionObservations& session,
                             const RangeImage& projection, const EngineConfig& engine,
                             ObservationSet* correspondences = nullptr,
                             std::vector<double>* reprojection_px = nullptr);

}  // namespace calibd
