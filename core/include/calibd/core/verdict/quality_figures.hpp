#pragma once
/// \file
/// What the verdict judges a solved session by: the quality figures the engine measures
/// (paper Table I's reprojection error, formal sigmas, stability, and the camera-LiDAR checks
/// beyond the paper), each documented where it is declared.

#include <Eigen/Core>
#include <array>
#include <cmath>
#include <limits>

#include "calibd/core/verdict/principal_point_check.hpp"

namespace calibd {

struct QualityFigures {
  double reprojection_mean_px = 0.0, reprojection_p95_px = 0.0;  ///< paper Table I metric
  /// Its median: a few boards the LiDAR resolves coarsely (one or two rings on them) raise the
  /// mean and the p95, a wrong extrinsic or board moves every board's corners.
  double reprojection_median_px = 0.0;
  /// The LiDAR's point spacing on the boards as the camera sees it, px: per board f s / d (s its
  /// BoardPointSpacingM, d its distance from the camera), mean over the boards. Each board's own
  /// fit, which the Table I metric measures, is as good as a share of it.
  double lidar_spacing_px = 0.0;
  /// The reprojection gate the verdict applied: VerdictConfig::max_reprojection_mean_deg at the
  /// camera's focal length, or kReprojectionSpacingShare of lidar_spacing_px where the LiDAR
  /// resolves the boards coarser (ReprojectionGatePx).
  double reprojection_gate_px = 0.0;
  double residual_rms_m = 0.0;
  int frames_used = 0, boards_used = 0;
  double min_distance_m = 0.0, max_distance_m = 0.0;  ///< camera-to-board distances used
  double image_coverage = 0.0;  ///< fraction of a 4x4 grid of image cells holding a board centre
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  double min_information_eigenvalue = 0.0;
  double rotation_sigma_deg = 0.0, translation_sigma_m = 0.0;  ///< formal, from J^T J
  /// The same from the cluster-robust covariance (clustered_covariance.hpp): honest about errors
  /// a board or a stretch of frames shares, widened for the few stretches it rests on
  /// (FewClustersVarianceFactor), never narrower than the formal one in any direction
  /// (ErrorBound); infinite where it cannot be estimated.
  double rotation_clustered_sigma_deg = std::numeric_limits<double>::infinity();
  double translation_clustered_sigma_m = std::numeric_limits<double>::infinity();
  /// What the systematic terms the checks measure could move the result by (ErrorBound in
  /// measure_quality.hpp): the principal point's turn, the range offset, the camera's scale and
  /// the time offset left, their estimates plus their sigmas at the bound's quantile.
  double rotation_systematic_deg = 0.0, translation_systematic_m = 0.0;
  /// The rotation bound's statistical part alone: the 99 % quantile of the norm of the clustered
  /// covariance's rotation error (as above: never narrower than the formal one), deg (infinite
  /// where it cannot be estimated). Within the tolerance while the whole bound is not: the
  /// systematic part took it beyond.
  double rotation_statistical_deg = std::numeric_limits<double>::infinity();
  /// The mean direction from the camera to the boards (unit, camera frame): the one along which
  /// a range offset, a scale error or a time offset moves the translation.
  Eigen::Vector3d board_direction = Eigen::Vector3d::UnitZ();
  /// The translation's systematic terms each alone (estimate plus sigma at the bound's
  /// quantile), m: what the error bound's gate names as the main cause.
  double translation_bound_range_offset_m = 0.0;
  double translation_bound_scale_m = 0.0;
  double translation_bound_time_offset_m = 0.0;
  /// ... and the principal point's, through its measured response (principal_point_response).
  double translation_bound_principal_point_m = 0.0;
  /// The rotation's time offset term alone (the offset left and its sigma through
  /// MeasureResponses), deg: named by the error bound's gate where it outweighs the principal
  /// point's.
  double rotation_bound_time_offset_deg = 0.0;
  /// The rotation's camera scale term alone (the scale error left and its sigma through
  /// MeasureResponses), deg.
  double rotation_bound_camera_scale_deg = 0.0;
  /// ... and the boards' centres about their tags, as the camera sees the boards' edges
  /// (board_centre_offset.hpp).
  double translation_bound_board_centre_m = 0.0;
  /// The board whose centre the camera sees furthest from the configured one in its sigmas: its
  /// id (-1: no board's outline measured), offset and sigma along x_B and y_B, m.
  int board_centre_offset_id = -1;
  Eigen::Vector2d board_centre_offset_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d board_centre_offset_sigma_m =
      Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  /// What the boards' centre offsets move the translation by where the solve takes them whole,
  /// m, and its covariance (BoardCentreOffsets): the error bound's board centre term.
  Eigen::Vector3d board_centre_translation_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d board_centre_translation_cov = Eigen::Matrix3d::Zero();
  /// The predicted bound on this result's own error (99 %): the systematic terms' estimates
  /// plus the 99 % quantile of the norm of the error the clustered covariance and their sigmas
  /// give (ErrorBound in measure_quality.hpp).
  double rotation_bound_deg = std::numeric_limits<double>::infinity();
  double translation_bound_m = std::numeric_limits<double>::infinity();
  /// Whether the session bounded its error at all (both bounds finite).
  bool has_error_bound() const {
    return std::isfinite(rotation_bound_deg) && std::isfinite(translation_bound_m);
  }
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
  /// The turn that shift gives the result: about |(dx / fx, dy / fy)|, deg, and the same of the
  /// shift's sigma.
  double principal_point_turn_deg = 0.0;
  double principal_point_turn_sigma_deg = std::numeric_limits<double>::infinity();
  /// The intrinsic calibration's stated sigma of the principal point (CalibConfig), px; 0: none.
  double principal_point_stated_sigma_px = 0.0;
  /// The tags' shift against that sigma and their own (StatedPrincipalPointChiSquare).
  double principal_point_stated_chi2 = 0.0;
  /// What the result takes the principal point to be (CombinePrincipalPoint: the tags and the
  /// stated sigma), as the turn it gives the result (deg) and that shift's sigma per axis as a
  /// turn (rad: along u, about the camera's y axis; along v): one per reading of the tags'
  /// corners, indexed by CornerBias. Infinite sigma: known neither from the tags nor from the
  /// intrinsic calibration.
  struct PrincipalPointTurn {
    double turn_deg = 0.0;
    Eigen::Vector2d sigma_rad = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    /// The same as a shift from the configured principal point and its sigma, px.
    Eigen::Vector2d shift_px = Eigen::Vector2d::Zero();
    Eigen::Vector2d sigma_px = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  };
  std::array<PrincipalPointTurn, kNumCornerBiasReadings> principal_point_beliefs{};
  /// The reading the error bound took (ErrorBound: the one whose bound is the larger), and its
  /// belief: the bound's rotation terms.
  CornerBias principal_point_bound_corners = CornerBias::kAssumed;
  PrincipalPointTurn principal_point_belief{};
  /// How the result moves per px of principal point shift along u and v, [dt (m), dtheta (rad)]
  /// (MeasureResponses, ResponsesAndBound): the bound carries the belief through it
  /// into both the rotation and the translation. Not measured: the rotation takes the turn d / f
  /// alone.
  bool principal_point_response_measured = false;
  Eigen::Matrix<double, 6, 2> principal_point_response = Eigen::Matrix<double, 6, 2>::Zero();
  double principal_point_ms = 0.0;
  /// How the result moves per second of camera time offset, [dt (m), dtheta (rad)]
  /// (MeasureResponses, ResponsesAndBound): the bound carries the offset left after the
  /// correction and its sigma through it. Not measured: the translation takes the sigma times
  /// the boards' normal speed.
  bool time_offset_response_measured = false;
  Eigen::Matrix<double, 6, 1> time_offset_response = Eigen::Matrix<double, 6, 1>::Zero();
  /// How the result moves per unit of camera scale error, [dt (m), dtheta (rad)]
  /// (MeasureResponses, ResponsesAndBound): the bound carries the scale error left after the
  /// correction and its sigma through it. Not measured: the translation takes them times the
  /// boards' distance.
  bool camera_scale_response_measured = false;
  Eigen::Matrix<double, 6, 1> camera_scale_response = Eigen::Matrix<double, 6, 1>::Zero();
};

/// The image coverage grid (QualityFigures::image_coverage, the agent's coverage gate): the image
/// in kImageGridSide x kImageGridSide cells.
inline constexpr int kImageGridSide = 4;
/// Cell (row * kImageGridSide + column) of a pixel of a width x height image; -1 outside.
int ImageCell(double u_px, double v_px, int width, int height);

}  // namespace calibd
