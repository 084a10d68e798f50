#pragma once
/// \file
/// The quality figures of a solved session (quality_figures.hpp), which the verdict's gates
/// judge: coverage, formal sigmas and residual, the camera-LiDAR checks beyond the paper (camera
/// scale, range offset, ring elevations, board flatness, principal point, time offset), the
/// planes' conditioning, and the stability and reprojection figures.

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
/// flatness, the principal point, the time offset left and the planes' conditioning.
void MeasureQuality(const CalibConfig& config, const SessionObservations& session,
                    const RangeImage& projection, const ObservationSet& corr,
                    const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                    QualityFigures* q);

/// How many re-solves the stability figures take.
struct StabilityChecks {
  int half_data_runs = 4;  ///< re-solves on random halves of the correspondences (0: skip)
  int start_checks = 1;    ///< solves of every board from other starts (0: skip)
};

/// The stability figures (re-solves on random halves, solves from other starts) and the
/// reprojection errors (each board fitted alone, started from its refined pose): independent tasks
/// shared out over the solver's threads (`solver.threads`). `reprojection_px`, when given, gets
/// each correspondence's mean corner error.
void MeasureStabilityAndReprojection(const StabilityChecks& checks,
                                     const DirectOptimizerConfig& solver,
                                     const ReprojectionGateConfig& gate,
                                     const std::vector<BoardGeometry>& boards,
                                     const CameraModel& camera, const ObservationSet& corr,
                                     const DirectResult& direct, QualityFigures* q,
                                     std::vector<double>* reprojection_px);

}  // namespace calibd
