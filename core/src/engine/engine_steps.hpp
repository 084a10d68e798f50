#pragma once
// Private to the engine: the steps Calibrate runs a session through (calibration_engine.cpp),
// each a kNone or the Reason of a refusal with `detail` giving its figures and what to do.

#include <string>
#include <vector>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd {

// What the engine cannot work from at all: an invalid engine config, clouds of another LiDAR
// model, no board seen by one of the sensors.
Reason CheckInputs(const CalibConfig& config, const SessionObservations& observed,
                   const EngineConfig& engine, std::string* detail);

// Clusters that stood still while the camera's boards moved are furniture (static_scenery.hpp):
// the session without them, held in `subset` when there were some; `observed` itself otherwise.
const SessionObservations& WithoutStaticScenery(const SessionObservations& observed,
                                                const StaticScenery& scenery,
                                                SessionObservations* subset);

// A LiDAR board cluster left once the static scenery is gone.
Reason CheckMovingClusters(const SessionObservations& session, const StaticScenery& scenery,
                           std::string* detail);

// The coarse grid search (paper §III-D) around the prior: its extrinsic and the correspondences
// it pairs. When no rotation in its range aligns the boards, whether one does with two boards'
// ids swapped (board_swap_check.hpp).
Reason SearchGrid(const CalibConfig& config, const SessionObservations& session,
                  const RangeImage& projection, const EngineConfig& engine,
                  GridSearchResult* result, ObservationSet* corr, std::string* detail);

// Each correspondence of a session without its static scenery names its cluster in the caller's
// session, not in the subset.
void NameClustersInTheSession(const SessionObservations& observed, const StaticScenery& scenery,
                              ObservationSet* corr);

// Enough correspondences after motion compensation, and camera distances that do not say two
// boards' ids are swapped (board_swap_check.hpp).
Reason CheckCorrespondences(const CalibConfig& config, const VerdictConfig& v,
                            const MotionCompensationStats& motion, const ObservationSet& corr,
                            const Pose& T_camera_lidar, const QualityFigures& q,
                            std::string* detail);

// The solution: the direct optimisation (paper §III-E) or the indirect baseline, from the grid
// search's extrinsic, with the camera's time offset and scale corrected where they are measured
// and the points and boards that do not fit dropped (solve_session.cpp). `dropped_total` counts
// the boards.
struct Solution {
  DirectResult direct;
  /// The boards as the solve sees them: the configured ones, their patterns scaled when the
  /// camera's scale was corrected.
  std::vector<BoardGeometry> boards;
  /// LiDAR points trimmed as off their boards (a stand's) before the final solve.
  int points_off_their_boards = 0;
};
Reason Solve(const CalibConfig& config, const EngineConfig& engine, const CameraModel& camera,
             const Pose& T_start, ObservationSet* corr, QualityFigures* q, int* dropped_total,
             Solution* solution, std::string* detail);

}  // namespace calibd
