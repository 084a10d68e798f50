#pragma once
/// \file
/// calibd-bench resolution: speed of the generic LiDAR's resolution estimate
/// (core/lidar_resolution.hpp) on one simulated workshop sweep of each LiDAR model.

namespace calibd::bench {

struct ResolutionBenchOptions {
  int repeat = 50;  ///< timed runs per model (--repeat)
};

/// Runs the benchmark, the table on stdout; returns the exit code.
int RunResolutionBench(const ResolutionBenchOptions& options);

}  // namespace calibd::bench
