#pragma once
/// \file
/// What one calibd-calibrate run produced, and report.json written from it (--report).

#include <nlohmann/json.hpp>
#include <string>
#include <vector>

#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "log_session.hpp"

namespace calibd::tools {

struct CalibrationRun {
  LidarModel lidar_model;                  ///< the config's, or estimated for generic
  LidarResolutionEstimate lidar_estimate;  ///< generic only
  SessionObservations session;             ///< the detections of every pair read
  LogReadStats stats;                      ///< the reading's counters
  double read_s = 0.0;                     ///< reading and detection, wall time
  std::string method;                      ///< "direct" or "indirect", as solved
  LogReadOptions read;                     ///< how the pairs were read (the model above in it)
  CalibrationOutcome outcome;
  ObservationSet correspondences;       ///< of the final solve
  std::vector<double> reprojection_px;  ///< per correspondence
  /// Hints a user can act on, empty when none: the LiDAR missed many boards; the pairs lie
  /// beyond the motion window.
  std::string lidar_hint, motion_hint;
  /// Against the simulator's truth (--truth); negative without it.
  double truth_rotation_deg = -1.0, truth_translation_m = -1.0;
};

/// report.json: verdict, reason, the transforms both ways, quality, the grid search, motion
/// compensation, the LiDAR model, the frames' counts and timings (--help lists them).
nlohmann::json ReportJson(const CalibrationRun& run, const CalibConfig& config,
                          const std::string& software_version);

}  // namespace calibd::tools
