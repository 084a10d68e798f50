#pragma once
/// \file
/// Paper Table I's metric: each board fitted alone in the LiDAR frame (Eq. 2-3) and its tag
/// corners mapped into the image, against the camera's detected corners.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/session/board_observation.hpp"
#include "calibd/core/solve/direct_optimizer.hpp"
#include "calibd/core/verdict/quality_figures.hpp"

namespace calibd {

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

/// Paper Table I errors of observations [begin, end) of `set` into errors_px[4k .. 4k+3] (NaN
/// where a corner has none). `T_camera_board_start` (one per observation, or empty): where each
/// board's fit starts.
void ReprojectionErrors(const std::vector<BoardGeometry>& boards, const CameraModel& camera,
                        const ObservationSet& set, const Pose& T_camera_lidar,
                        const DirectOptimizerConfig& direct,
                        const std::vector<Pose>& T_camera_board_start, size_t begin, size_t end,
                        double* errors_px);

/// The mean and p95 over every corner error that is not NaN (QualityFigures::reprojection_*).
void ReprojectionFigures(std::vector<double> errors_px, QualityFigures* q);

/// The LiDAR's point spacing on one board, m in the board's plane: the root mean square of its
/// coarsest and its finest axis. A ring LiDAR's rows leave gaps on a board far wider than its
/// spacing along a row, and each board's own fit (the Table I metric) can slide across a gap:
/// the isotropic sqrt(A / n) (A the board's area, n its points) understates where it lies. The
/// coarse axis is the widest gap between neighbouring points in elevation or in azimuth as the
/// LiDAR sees them (the outermost point on each side left out, so that one stray point does not
/// make a gap), no finer than sqrt(A / n) nor wider than the board; the fine one keeps A / n.
double BoardPointSpacingM(const Eigen::Vector3f* points, int count, double width_m,
                          double height_m);

/// Per observation, the mean of its four corners' errors (those not NaN; NaN when none is).
void MeanCornerErrors(const std::vector<double>& errors_px, std::vector<double>* mean_px);

}  // namespace calibd
