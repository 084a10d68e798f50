#pragma once
/// \file
/// The quality figures of a solved session (quality_figures.hpp), which the verdict's gates
/// judge: coverage, formal sigmas and residual, the camera-LiDAR checks beyond the paper (camera
/// scale, range offset, ring elevations, board flatness, principal point, time offset), the
/// planes' conditioning, and the stability and reprojection figures.

#include <array>
#include <functional>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/board_observation.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/core/solve/direct_optimizer.hpp"
#include "calibd/core/verdict/gates/reprojection_gate.hpp"
#include "calibd/core/verdict/quality_figures.hpp"

namespace calibd {

/// The correspondences' counts, distances, image coverage and the LiDAR's point spacing on the
/// boards (QualityFigures::frames_used .. image_coverage, lidar_spacing_px).
void CoverageFigures(const CalibConfig& config, const ObservationSet& set, QualityFigures* q);

/// The quality figures of a solution (`direct`, over `boards` as the solve saw them): its formal
/// sigmas and residual, the camera's scale and the LiDAR's range offset, ring elevations, board
/// flatness, the principal point, the boards' centres about their tags, the time offset left and
/// the planes' conditioning. The responses and the error bound follow (ResponsesAndBound).
void MeasureQuality(const CalibConfig& config, const SessionObservations& session,
                    const RangeImage& projection, const ObservationSet& corr,
                    const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                    QualityFigures* q);

/// The time offset's step for the time offset's response (MeasureResponses), s: small against the
/// boards' motion between frames, large against the solve's tolerance. Boards carried during still
/// poses move across the view as well as along their normals: the offset left after the
/// correction turns the result, which the boards' normal speed alone misses.
inline constexpr double kTimeOffsetResponseStepS = 0.01;

/// The camera scale's step for its response (MeasureResponses): the camera's board distances 1 %
/// longer, as a tag size or focal length 1 % off makes them.
inline constexpr double kCameraScaleResponseStep = 0.01;

/// The error bound's measured responses of the extrinsic: to the principal point, per px along u
/// and v (PrincipalPointShiftedBoards), to the camera's time offset, per s (the compensated
/// points moved to a capture time kTimeOffsetResponseStepS later, ShiftToCaptureTime), and to the
/// camera's scale, per unit of relative error (every held board pose's translation scaled by
/// 1 + kCameraScaleResponseStep: boards spread across the view then turn the result as well as
/// move it, which the boards' mean distance alone misses). Each is
/// the extrinsic re-solved with the solution's board poses held (SolveHeldBoardsByGaussNewton) and
/// the data moved, less the same re-solve of the data as they are (so that the re-solve's own
/// settings cancel), over the shift: measured, not modelled.
struct Responses {
  bool principal_point = false;  ///< measured (every board's pose found with the shift)
  Eigen::Matrix<double, 6, 2> per_principal_point_px = Eigen::Matrix<double, 6, 2>::Zero();
  bool time_offset = false;  ///< measured (the points were motion-compensated)
  Eigen::Matrix<double, 6, 1> per_time_offset_s = Eigen::Matrix<double, 6, 1>::Zero();
  bool camera_scale = false;  ///< measured
  Eigen::Matrix<double, 6, 1> per_camera_scale = Eigen::Matrix<double, 6, 1>::Zero();
};

/// The responses of `direct` (over `corr`, `boards` as the solve saw them), on one thread, with
/// the re-solves' point budget (ReSolveSettings of `solver`).
Responses MeasureResponses(const CameraIntrinsics& camera, const std::vector<BoardGeometry>& boards,
                           const ObservationSet& corr, const DirectResult& direct,
                           const DirectOptimizerConfig& solver);

/// The responses into `q` (QualityFigures::principal_point_response, time_offset_response,
/// camera_scale_response), then
/// the error bound (ErrorBound). After MeasureQuality.
void ResponsesAndBound(const Responses& responses, const DirectResult& direct, QualityFigures* q);

/// How much wider the clustered covariance is taken for the bound, as a variance factor, when it
/// rests on `clusters` stretches of frames: a covariance estimated from G clusters has G - 1
/// degrees of freedom, so its 3-D Wald statistic is referred to 3 F(3, G - 1) instead of
/// chi-square(3) (Cameron & Miller, "A practitioner's guide to cluster-robust inference", 2015):
/// 3 F(3, G - 1; 0.99) / chi2(3; 0.99), 2.24 for the direct solve's 8 stretches.
double FewClustersVarianceFactor(int clusters);

/// The 99 % quantile of the norm of a 3-D Gaussian error along its worst direction (the square
/// root of chi-square with 3 degrees of freedom at 0.99), which the error bound scales its
/// standard deviations by.
inline constexpr double kBoundNormQuantile3d = 3.368;
/// The two-sided 99 % quantile of a 1-D Gaussian: a systematic term's share of the bound
/// (QualityFigures::translation_bound_range_offset_m and the like).
inline constexpr double kBoundQuantile1d = 2.576;

/// The 99 % quantile of the norm of a 3-D Gaussian error of `covariance` (zero mean): between
/// the square root of its largest eigenvalue times 2.576 (one direction) and times
/// kBoundNormQuantile3d (three alike). Infinite for a covariance that is not finite.
double GaussianNormQuantile99(const Eigen::Matrix3d& covariance);

/// The predicted 99 % bound on the result's own error (QualityFigures::rotation_bound_deg,
/// translation_bound_m and their parts), from `direct`'s clustered covariance (widened by
/// FewClustersVarianceFactor) and the systematic figures MeasureQuality set in `q`. Rotation: the
/// principal point as the tags and the intrinsic calibration know it together
/// (principal_point_beliefs), which the LiDAR cannot see, in the reading of the tags' corners
/// (CornerBias) whose bound is the larger. Translation, each along the boards'
/// direction: the LiDAR's range offset (moves it by about itself), the camera's scale error left
/// after its correction and its sigma (by themselves times the boards' distance), the time
/// offset's sigma (times the boards' speed along their normals). What a check estimated and left
/// uncorrected is a bias, added as it is; the estimates' variances join the clustered covariance,
/// and the bound adds the 99 % quantile of that error's norm (GaussianNormQuantile99). The
/// principal point known neither way, or no clustered covariance: the bound is infinite. A
/// translation term not measured adds nothing: its own gate decides about it. The verdict
/// accepts a result only inside its tolerance (error_bound_gate.hpp); `calibd-bench verdicts`
/// measures how often the true error lies inside it.
void ErrorBound(const DirectResult& direct, QualityFigures* q);

/// How many re-solves the stability figures take.
struct StabilityChecks {
  int half_data_runs = 4;  ///< re-solves on random halves of the correspondences (0: skip)
  int start_checks = 1;    ///< solves of every board from other starts (0: skip)
};

/// The stability figures (re-solves on random halves, solves from other starts) and the
/// reprojection errors (each board fitted alone, started from its refined pose): independent tasks
/// shared out over the solver's threads (`solver.threads`). Each of `alongside` runs as one more
/// of those tasks, in order after the start checks (MeasureQuality, which writes other figures of
/// `q`, and the response re-solves), so that they share the threads too. `reprojection_px`, when
/// given, gets each correspondence's mean corner error.
void MeasureStabilityAndReprojection(const StabilityChecks& checks,
                                     const DirectOptimizerConfig& solver,
                                     const ReprojectionGateConfig& gate,
                                     const std::vector<BoardGeometry>& boards,
                                     const CameraModel& camera, const ObservationSet& corr,
                                     const DirectResult& direct,
                                     const std::vector<std::function<void()>>& alongside,
                                     QualityFigures* q, std::vector<double>* reprojection_px);

}  // namespace calibd
