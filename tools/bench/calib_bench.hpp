#pragma once
/// \file
/// `calibd-bench calib`: calibrates simulated drives with the real detectors and engine and
/// reports the paper's experiments (§IV): accuracy and timing per LiDAR against our targets, the
/// alpha sweep of Table I, the close/far comparison of Table II, the sampling-distance STD of
/// Fig. 7 and the grid search's convergence from +-10 deg priors (§IV-D).

#include <iosfwd>
#include <string>
#include <vector>

namespace calibd::bench {

struct CalibBenchOptions {
  std::vector<std::string> lidars{"ot128", "m1", "falcon"};
  int trajectories = 5;  ///< drives per LiDAR: seeds seed .. seed + trajectories - 1 (paper: 5)
  int frames = 200;      ///< frame pairs per drive (paper: 200)
  unsigned long long seed = 1;
  int trials = 100;       ///< grid-search trials with and without the search (paper: 100 each)
  std::string json_path;  ///< also write the figures as JSON
};

/// Runs the bench, printing tables to `out` and progress to `progress`. Returns false with
/// `error` when a session or detector could not be set up.
bool RunCalibBench(const CalibBenchOptions& options, std::ostream& out, std::ostream* progress,
                   std::string* error);

}  // namespace calibd::bench
