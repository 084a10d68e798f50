#pragma once
/// \file
/// `calibd-bench time-offset`: the camera's time offset against the LiDAR, estimated by the engine
/// from the boards' motion (board_motion.hpp, EstimateTimeOffset), over simulated drives with the
/// camera running 0-100 ms late. Two ways a recording gets its stamps wrong: the camera stamped
/// at its trigger, and each pair stamped with one time (its LiDAR sweep's start), as a user
/// writes frames.csv for pairs matched by file name. And one drive that only approaches the boards,
/// where the offset cannot be told from a translation. Per drive: the offset and its estimate,
/// the sigma, the error of the extrinsic and the verdict.

#include <ostream>
#include <string>
#include <vector>

namespace calibd::bench {

struct TimeOffsetBenchOptions {
  std::vector<std::string> lidars = {"ot128", "m1"};
  unsigned long long seed = 1;
  int threads = 2;
  std::string json_path;
};

/// Runs the drives and prints the table; false with `error` when a drive could not be simulated.
bool RunTimeOffsetBench(const TimeOffsetBenchOptions& options, std::ostream& out,
                        std::ostream* progress, std::string* error);

}  // namespace calibd::bench
