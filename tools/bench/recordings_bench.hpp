#pragma once
/// \file
/// `calibd-bench recordings`: the sessions people record on their own rigs, simulated: still poses
/// of one board at 1.5-10 m (tripod or held by hand, turned, furniture and people near it) seen by
/// LiDARs other than ours (16-ring, 32-ring, 64-ring, Livox-like non-repetitive) and pinhole or
/// fisheye cameras, each calibrated from a config that holds only what a user knows (board
/// geometry, intrinsics, the LiDAR model's name, a nominal prior). Prints, per scenario, the
/// LiDAR's board recall and precision, the verdict and the error against the truth, and the grid
/// search's convergence from priors rotated by up to +-10 deg, against the targets.

#include <ostream>
#include <string>
#include <vector>

#include "calibd/core/session/config.hpp"

namespace calibd::bench {

struct RecordingsBenchOptions {
  std::vector<std::string> scenarios;  ///< names; empty: every scenario
  unsigned long long seed = 1;
  int grid_trials = 20;        ///< grid-search convergence trials per scenario (0 skips)
  bool extract_planes = true;  ///< LidarDetectorConfig::extract_planes (calibd-calibrate's default)
  std::string json_path;
};

/// A 1920 x 1200 machine-vision camera with a 6 mm-class lens, or a ~190 deg fisheye on 1600 x
/// 1200: the cameras of the scenarios (and of calibd-bench verdicts).
CameraIntrinsics ScenarioCamera(bool fisheye);

/// Every scenario's name, comma-separated (for --help and errors).
std::string RecordingScenarioNames();

/// Runs the scenarios and prints the table; false with `error` when a scenario could not be
/// simulated (a failed target is reported in the table, and makes the result false too).
bool RunRecordingsBench(const RecordingsBenchOptions& options, std::ostream& out,
                        std::ostream* progress, std::string* error);

}  // namespace calibd::bench
