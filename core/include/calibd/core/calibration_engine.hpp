#pragma once
/// \file
/// The session-level calibration: coarse grid search (paper §III-D), direct optimisation (§III-E,
/// or the indirect baseline), quality figures, and the verdict against the prior calibration.
///
/// Verdicts: `verified` (the new estimate agrees with the prior within the verification
/// tolerance: the prior is kept), `updated` (a plausible change and every quality gate passes),
/// `rejected` with a Reason (reason.hpp, which says what each one means; the operator guide's
/// troubleshooting table says what to do).

#include <limits>
#include <string>
#include <vector>

#include "calibd/core/board_motion.hpp"
#include "calibd/core/camera_model.hpp"
#include "calibd/core/config.hpp"
#include "calibd/core/direct_optimizer.hpp"
#include "calibd/core/grid_search.hpp"
#include "calibd/core/indirect_optimizer.hpp"
#include "calibd/core/principal_point_check.hpp"
#include "calibd/core/range_image.hpp"
#include "calibd/core/reason.hpp"
#include "calibd/core/session_observations.hpp"
#include "calibd/core/static_scenery.hpp"

namespace calibd {

struct VerdictConfig {
  double verify_rotation_deg = 0.15;  ///< below both: `verified`, the prior is kept
  double verify_translation_m = 0.015;
  /// Mechanical tolerance: beyond it, `rejected`. A nominal prior from the mounting drawings is
  /// within about 10 deg / 20 cm of the truth (the grid search's reach), so a first calibration
  /// from one must pass it.
  double max_rotation_deg = 10.0;
  double max_translation_m = 0.20;
  /// The least data the engine solves with. The verdict rests on the evidence (the formal
  /// sigmas, the plane conditioning, the half-data spread, the residuals), not on counts: a dozen
  /// well-spread still poses of one board can pass, two hundred frames of one board far away
  /// cannot. A board correspondence fixes a plane; six leave each half of the half-data
  /// re-solves about three, the fewest non-parallel planes that fix all six degrees of freedom.
  /// Frames add nothing by themselves: one shot of a wall of boards counts like six shots of one.
  int min_frames = 1;                    ///< frame pairs with at least one correspondence
  int min_boards = 6;                    ///< board correspondences
  double max_rotation_sigma_deg = 0.05;  ///< formal standard deviation gates (precision)
  double max_translation_sigma_m = 0.01;
  /// Degeneracy gate: smallest / largest eigenvalue of the board-plane information, rotations
  /// scaled by a 10 m lever arm. One board, or parallel boards, drive it towards 0.
  double min_plane_conditioning =
      1e-5;  // measured: 3 spread boards 9e-5, one board 1e-6, parallel 2e-8
  double max_rotation_spread_deg = 0.25;  ///< half-data re-solve gates (stability)
  double max_translation_spread_m = 0.03;
  /// Start gates (stability): the solves from EngineConfig::start_checks other starts must end
  /// this close to the solution; farther, the cost has another minimum there. Within one minimum
  /// they end a few hundredths of a degree apart (half the points each, and the board-pose
  /// alternation stops short of the joint optimum); a minimum closer than two thirds of the
  /// verification tolerance would not change what the verdict means.
  double max_start_rotation_deg = 0.1;
  double max_start_translation_m = 0.01;
  /// Scale (QualityFigures::camera_scale_error): a tag size or focal length 1 % off moves the
  /// translation by 1 % of the boards' distance, more than the verification tolerance beyond a
  /// metre and a half. Measured beyond kScaleSigmas of its sigma, the session is corrected for it
  /// up to this share (QualityFigures::camera_scale_corrected); beyond, the configuration is wrong
  /// and the verdict is `camera_scale_mismatch`.
  double max_camera_scale_error = 0.015;
  /// Range offset gate (QualityFigures::lidar_range_offset_m): beyond this and kRangeOffsetSigmas
  /// of its sigma, `lidar_range_offset`. An offset moves the translation by about as much along the
  /// boards' mean direction, so the gate is the verification tolerance. Measured less precisely
  /// (its sigma above kMeasuredRangeOffsetShare of the gate) it does not fire; not measured to
  /// kRangeOffsetSigmaTolerances verification tolerances, the verdict is `poor_observability`.
  double max_lidar_range_offset_m = 0.015;
  /// Time offset gate (QualityFigures::time_offset_s): the solution is corrected for the camera's
  /// offset against the LiDAR up to this (how well: calibd-bench time-offset); beyond it and
  /// kTimeOffsetSigmas of its sigma the stamping is broken rather than late, and the verdict is
  /// `time_offset_beyond_tolerance`. A session that cannot measure the offset (still boards, no
  /// capture times, or a drive whose boards' speed along their normals hardly varies) relies on the
  /// stamps: QualityFigures says how far an offset as large as its sigma would move the
  /// translation.
  double max_time_offset_s = 0.1;
  /// Paper Table I metric. It measures each board's own LiDAR fit as much as the extrinsic:
  /// correct results stay well under it (calibd-bench calib's Table I), and a rotation error of
  /// 0.1 deg adds fx * 0.1 deg, about 6 px at fx = 3325 px: 8 px still catches errors near the
  /// verification tolerance.
  double max_reprojection_mean_px = 8.0;  ///< raised for a sparse LiDAR: reprojection_gate_px
  double max_residual_rms_m = 0.05;
};

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

/// Boards the camera-LiDAR scale fit needs (4 unknowns and a residual to measure), and the
/// spread of their distances, as a share of the farthest.
inline constexpr int kMinScaleBoards = 8;
inline constexpr double kMinScaleDistanceSpread = 0.3;
/// A scale error counts only beyond this many of its standard deviations.
inline constexpr double kScaleSigmas = 3.0;
/// Flatness gate (QualityFigures::board_bend_m): a board whose face bends more than this at its
/// centre line, beyond kBoardBendSigmas of its sigma, is `board_not_flat`. The operator guide asks
/// for 2 mm, within which the bend is measured on clean boards: the gate leaves room above it.
/// A property of the boards, not a tolerance of the result: not configurable.
inline constexpr double kMaxBoardBendM = 0.005;
/// Ring gate (QualityFigures::ring_elevation_*): the rings' elevation deltas scatter by more than
/// kRingElevationChi2 times their variance (mean squared sigmas) and by more than
/// kMinRingElevationRmsDeg: `lidar_ring_elevation`. Set between what clean ring LiDARs' sessions
/// scatter by and what lasers off their table by enough to move the result make
/// (docs/performance-and-reliability.md, "Why the thresholds are where they are").
inline constexpr double kRingElevationChi2 = 10.0;
inline constexpr double kMinRingElevationRmsDeg = 0.05;
inline constexpr double kBoardBendSigmas = 4.0;
/// A range offset counts only beyond this many of its standard deviations: its sigma underrates
/// the in-plane centres' errors shared by a session's boards (clean sessions measured offsets of
/// three to four sigmas: docs/performance-and-reliability.md, "Why the thresholds are where they
/// are").
inline constexpr double kRangeOffsetSigmas = 4.0;
/// A range offset counts only when measured to this share of its gate: its sigma comes from the
/// boards' scatter, which underrates errors shared by all of a session's boards (the in-plane
/// centres' from the scan pattern's density, the plane distances' from PnP's bias).
inline constexpr double kMeasuredRangeOffsetShare = 0.5;
/// A range offset moves the translation by up to as much (all of it for boards straight ahead), so
/// a result is accepted only where the boards measure it at all: with a sigma of at most this
/// many verification tolerances (VerdictConfig::verify_translation_m); the rest is
/// `poor_observability`. Between kMeasuredRangeOffsetShare of the range gate and this, the
/// translation is as good as the LiDAR's range calibration (report.json gives the sigma): a
/// tighter bound refused clean m1 drives with a small camera, whose far boards' small tags bias
/// the in-plane centres (calibd-bench calib, Fig. 7 subsets; SensorFaultsTest).
inline constexpr double kRangeOffsetSigmaTolerances = 4.0;
/// The translation rests on the camera's board distances (PnP, through the tag's size in the
/// image) wherever the LiDAR cannot pin the boards along their normals by itself: a scale error as
/// large as the scale's sigma moves it by that sigma times the boards' mean distance
/// (QualityFigures::camera_scale_translation_m). Beyond this many verification tolerances the
/// result is `poor_observability`: small far tags measure their distance too loosely, and their
/// corner bias is then taken for a scale, a range offset or a time offset and corrected for,
/// centimetres off (CalibrationEngineTest.SmallFarTagsAreRefusedNotTrusted).
inline constexpr double kScaleTranslationTolerances = 1.0;
/// A principal point shift counts only when its chi-square (two degrees of freedom, each axis
/// over its sigma) is beyond this: the 3-sigma probability, 0.27 %.
inline constexpr double kPrincipalPointChiSquare = 11.83;
/// ... and when the turn it gives the result is beyond this many verification tolerances
/// (VerdictConfig::verify_rotation_deg): the tags' fit carries biases of its own beyond its sigma
/// (corner localisation under perspective), so the gate refuses what would make the result wrong,
/// not what a correct camera's fit scatters by.
inline constexpr double kPrincipalPointTurnTolerances = 2.0;
/// The turn compared with them is the measured one raised by this many of its sigmas: a shift
/// shown to be there can be that much larger than measured, and the extrinsic takes up the true
/// one (docs/performance-and-reliability.md, "Why the thresholds are where they are").
inline constexpr double kPrincipalPointTurnSigmas = 2.0;
/// A principal point whose sigma alone turns the result by more than this many of those turns is
/// refused too: the tags disagree with each other, as a wrong lens model makes them (the figures:
/// docs/performance-and-reliability.md, "Why the thresholds are where they are").
inline constexpr double kPrincipalPointSigmaTurns = 2.0;
/// ... when their corners also fit the lens model worse than this (RMS, px): three times the
/// corner precision the fit assumes (kCornerNoisePx). A short session's groups can scatter as
/// much with corners that fit, while a wrong lens leaves them misfit (the same section).
inline constexpr double kLensMisfitResidualPx = 3.0 * kCornerNoisePx;
/// A time offset is corrected for only beyond this many of its standard deviations.
inline constexpr double kTimeOffsetSigmas = 3.0;

/// The mean reprojection error a correct result stays under, as a share of the LiDAR's point
/// spacing on the boards (QualityFigures::lidar_spacing_px): each board's fit places its tag
/// corners to about a third of a spacing (clean sessions of ring, MEMS and non-repetitive LiDARs,
/// calibd-bench verdicts), so a sparse LiDAR's boards miss by more pixels than a dense one's
/// whatever the extrinsic.
inline constexpr double kReprojectionSpacingShare = 0.6;

struct QualityFigures {
  double reprojection_mean_px = 0.0, reprojection_p95_px = 0.0;  ///< paper Table I metric
  /// The LiDAR's point spacing on the boards as the camera sees it, px: per board f sqrt(A / n) / d
  /// (A the board's area, n its LiDAR points, d its distance from the camera), mean over the
  /// boards. Each board's own fit, which the Table I metric measures, is as good as a share of it.
  double lidar_spacing_px = 0.0;
  /// The reprojection gate the verdict applied: VerdictConfig::max_reprojection_mean_px, or
  /// kReprojectionSpacingShare of lidar_spacing_px where the LiDAR resolves the boards coarser.
  double reprojection_gate_px = 0.0;
  double residual_rms_m = 0.0;
  int frames_used = 0, boards_used = 0;
  double min_distance_m = 0.0, max_distance_m = 0.0;  ///< camera-to-board distances used
  double image_coverage = 0.0;  ///< fraction of a 4x4 grid of image cells holding a board centre
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double min_information_eigenvalue = 0.0;
  double rotation_sigma_deg = 0.0, translation_sigma_m = 0.0;  ///< formal, from J^T J
  double plane_conditioning = 0.0;  ///< see VerdictConfig::min_plane_conditioning
  double rotation_spread_deg = 0.0, translation_spread_m = 0.0;  ///< half-data re-solves
  double start_rotation_deg = 0.0, start_translation_m = 0.0;    ///< solves from other starts
  /// Camera-LiDAR scale agreement (EstimateCameraScale): the relative error of the camera's board
  /// distances against the LiDAR's, fitted over the boards with what a translation explains
  /// taken out, and its standard deviation; NaN with fewer than kMinScaleBoards boards. A wrong
  /// tag size or focal length scales every PnP distance; a translation cannot absorb that.
  double camera_scale_error = std::numeric_limits<double>::quiet_NaN();
  double camera_scale_sigma = std::numeric_limits<double>::quiet_NaN();
  /// What the solution was corrected for (the camera's patterns and distances scaled by
  /// 1 / (1 + it)): the scale error when it exceeded kScaleSigmas of its sigma and stayed within
  /// VerdictConfig::max_camera_scale_error, else 0. camera_scale_error includes it.
  double camera_scale_corrected = 0.0;
  /// How far a scale error as large as its sigma moves the translation (sigma x the boards'
  /// distance): what the result rests on the tag size for; NaN where the scale is not fitted.
  double camera_scale_translation_m = std::numeric_limits<double>::quiet_NaN();
  /// A constant LiDAR range offset fitted in the same way (with the scale and a translation),
  /// m, and its standard deviation: large when the boards' directions cannot tell it from a
  /// translation (all in front of the LiDAR). NaN with too few boards.
  double lidar_range_offset_m = std::numeric_limits<double>::quiet_NaN();
  double lidar_range_offset_sigma_m = std::numeric_limits<double>::quiet_NaN();
  /// The camera's time offset against the LiDAR (s; positive: the camera exposed later than its
  /// stamps say) and its sigma, from the boards' motion (board_motion.hpp, EstimateTimeOffset);
  /// not fitted (sigma infinite) without moving boards or capture times. `time_offset_corrected_s`
  /// is what the solution was corrected for: the offset when it exceeded kTimeOffsetSigmas of its
  /// sigma, else 0.
  bool time_offset_fitted = false;
  double time_offset_s = 0.0;
  double time_offset_sigma_s = std::numeric_limits<double>::infinity();
  double time_offset_corrected_s = 0.0;
  /// RMS speed of the boards along their normals (m/s) in the observations with a velocity.
  double board_normal_speed_mps = 0.0;
  /// The principal point the tags fit against the configured one (principal_point_check.hpp),
  /// px, and its sigma; not fitted with too few camera observations.
  bool principal_point_fitted = false;
  Eigen::Vector2d principal_point_shift_px = Eigen::Vector2d::Zero();
  Eigen::Vector2d principal_point_sigma_px =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  /// RMS of the tags' corner residuals in that fit, px (PrincipalPointEstimate).
  double principal_point_residual_px = 0.0;
  /// What a corner bias common to every tag could move the shift by (PrincipalPointEstimate).
  Eigen::Vector2d principal_point_systematic_px =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  /// The most bent board (board_flatness.hpp): its id, the bend at its centre line (m, towards
  /// the sensors positive; about its vertical or horizontal axis, whichever is the more
  /// significant) and its sigma; id -1 when no board's bend was measured.
  /// Ring LiDARs: the lasers' elevations against the model's table (ring_elevations.hpp): rings
  /// measured, RMS of their deltas about the mean (deg) and the mean squared delta in sigmas.
  int ring_elevation_rings = 0;
  double ring_elevation_rms_deg = 0.0;
  double ring_elevation_chi2 = 0.0;
  int board_bend_id = -1;
  double board_bend_m = 0.0;
  double board_bend_sigma_m = std::numeric_limits<double>::infinity();
  /// The turn that shift gives the result: about |(dx / fx, dy / fy)|, deg.
  double principal_point_turn_deg = 0.0;
  double principal_point_ms = 0.0;
};

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
  /// its predicted region). See DropBoardsThatDoNotFit in calibration_engine.cpp.
  int dropped_correspondences = 0;
  GridSearchResult grid;
  MotionCompensationStats motion;
  /// Board-pose refinement (DirectOptimizerConfig::refine_board_poses): boards refined and the
  /// mean change of their poses from the camera's PnP, rotation (deg) and translation (m).
  int refined_boards = 0;
  double board_rotation_change_deg = 0.0, board_translation_change_m = 0.0;
  double optimise_ms = 0.0, quality_ms = 0.0;
};

const char* VerdictName(CalibrationOutcome::Verdict v);

/// Camera-LiDAR distance agreement (board_distances.hpp). Per board, the camera's distance to its
/// plane along the normal n (PnP) and the LiDAR's (its points under the solution). A tag size or
/// focal length wrong by a factor 1 + e makes every camera distance (1 + e) d; a translation
/// error c adds n . c; a LiDAR range offset b adds b (n . u), u the mean ray to the board's
/// points. The least-squares fit of d_camera - d_lidar = e d_camera + n . c + b (n . u) gives e
/// (what a translation cannot explain) and b, each with the larger of its least-squares and
/// cluster-robust sigmas; e without b where the boards leave b undetermined. The range offset
/// the quality figures report is the more precise of that b and the in-plane centres'
/// (FitRangeOffset, calibration_engine.cpp).
struct CameraScaleEstimate {
  /// Fitted over kMinScaleBoards boards or more whose distances spread by
  /// kMinScaleDistanceSpread of the farthest.
  bool scale_fitted = false;
  double scale = 0.0;  ///< e: the camera's distances are 1 + e times the LiDAR's
  double scale_sigma = std::numeric_limits<double>::infinity();
  bool range_offset_fitted = false;
  double range_offset_m = 0.0;
  double range_offset_sigma_m = std::numeric_limits<double>::infinity();
  /// The boards' mean distance: a scale e moves the translation by about e distance_m.
  double distance_m = 0.0;
};

/// The camera's scale is corrected only where it would move the translation by more than this
/// many verification tolerances (VerdictConfig::verify_translation_m; twice is where a result
/// becomes wrong): the fit also measures 0.1-0.3 % on correct cameras, PnP's bias on small far
/// tags and, in drives with a camera 40-100 ms late, scales that moved the corrected result
/// further from the truth (calibd-bench verdicts).
inline constexpr double kCorrectedScaleTolerances = 2.0;
/// The cluster-robust sigma counts over this many blocks of a board's frames (fewer, e.g. still
/// poses, leave only the least-squares one).
inline constexpr int kMinScaleClusterBlocks = 8;

/// From the set's BoardDistances under the solution (shared with EstimateTimeOffset).
CameraScaleEstimate EstimateCameraScale(const ObservationSet& set,
                                        const std::vector<BoardDistance>& distances);

/// The camera's view of a session whose patterns are `factor` times their configured size:
/// every PnP distance scales by it (PnP is scale-equivariant), so each observation's board
/// translation and velocity does, and the patterns' sizes in `boards` (the corners the board-pose
/// refinement fits). The boards' outlines, which the LiDAR measures, stay.
void ScaleCameraPatterns(double factor, std::vector<BoardGeometry>* boards, ObservationSet* set);

/// The image coverage grid (QualityFigures::image_coverage, the agent's coverage gate): the image
/// in kImageGridSide x kImageGridSide cells.
inline constexpr int kImageGridSide = 4;
/// Cell (row * kImageGridSide + column) of a pixel of a width x height image; -1 outside.
int ImageCell(double u_px, double v_px, int width, int height);

/// Paper Table I metric for one observation: fit its board alone in the LiDAR frame (Eq. 2-3,
/// from the camera's board pose through T_camera_lidar) and map the fitted tag corners into the
/// image. Corners that do not project are NaN. False when the fit fails. The fit starts from
/// `T_camera_board_start` when given (e.g. the solve's refined board pose, from which it converges
/// in fewer steps to the same fit), else from the camera's PnP pose.
bool FittedTagCornersPx(const CameraModel& camera, const std::vector<BoardGeometry>& boards,
                        const ObservationSet& set, const BoardObservation& observation,
                        const Pose& T_camera_lidar, const DirectOptimizerConfig& direct,
                        std::array<Eigen::Vector2d, 4>* px,
                        const Pose* T_camera_board_start = nullptr);

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
