#pragma once
/// \file
/// `calibd-bench verdicts`: the fault campaign. Simulated sessions (every LiDAR model, drives and
/// still poses, 1-3 boards), each clean or with one fault from a catalogue (wrong clocks, wrong
/// sizes or intrinsics in the config, a biased LiDAR, a prior beyond the grid search's reach) at a
/// random magnitude, detected and calibrated by the real detectors and engine. Per fault family
/// and overall: how often the verdict is right, and above all how often it accepts a wrong answer.

#include <ostream>
#include <string>
#include <vector>

namespace calibd::bench {

struct VerdictsBenchOptions {
  int sessions = 400;  ///< drawn round-robin over the fault families, LiDAR models and modes
  unsigned long long seed = 1;
  /// Short drives and few poses: 144 sessions in 4-5 minutes (not yet in make test).
  bool quick = false;
  int threads = 2;  ///< sessions calibrated at once
  /// Only these sessions (indices of a full run with the same seed and mode): to look again at
  /// one. Empty: sessions 0 .. sessions - 1.
  std::vector<int> only;
  std::string json_path;
};

/// The fault families' names, comma-separated (for --help).
std::string VerdictFaultNames();

/// Runs the campaign and prints the tables; false with `error` when a session could not be
/// simulated, or when any session was a false accept (an accepted answer beyond 2x the
/// verification tolerance).
bool RunVerdictsBench(const VerdictsBenchOptions& options, std::ostream& out,
                      std::ostream* progress, std::string* error);

}  // namespace calibd::bench
