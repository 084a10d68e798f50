#pragma once
/// \file
/// calibd-bench resolution: speed of the generic LiDAR's resolution estimate
/// (core/lidar_resolution.hpp) on one simulated workshop sweep of each LiDAR model.

namespace calibd::bench {

/// Runs the benchmark with the options after the command (`--repeat N`); returns the exit code.
int RunResolutionBench(int argc, char** argv);

}  // namespace calibd::bench
