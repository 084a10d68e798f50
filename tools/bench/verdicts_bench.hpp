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
  /// Sessions just above the agent's minimum (60-pair drives, 14 poses of 4 sweeps) instead of
  /// at its target (200 pairs): several times faster (not yet in make test).
  bool quick = false;
  int threads = 2;  ///< sessions calibrated at once
  /// Only these sessions (indices of a full run with the same seed and mode): to look again at
  /// one. Empty: sessions 0 .. sessions - 1.
  std::vector<int> only;
  /// Only the sessions of these faults (names as VerdictFaultNames(); "none": the clean
  /// sessions, for the false rejects alone). Empty: every fault.
  std::vector<std::string> faults;
  /// A round's sessions whose faults change only the config, the stamps, the order of the pairs,
  /// the LiDAR's noise or the camera take what they can of its clean session's recording (one
  /// simulation and detection for all: the same answers as each on its own, several times
  /// faster). False: every session simulated and detected on its own.
  bool share_recordings = true;
  std::string json_path;
};

/// The fault families' names, comma-separated (for --help).
std::string VerdictFaultNames();

/// Whether `name` is one of VerdictFaultNames().
bool IsVerdictFault(const std::string& name);

/// The sessions a run takes, in order: `only` (or 0 .. sessions - 1), less those whose fault is
/// not one of `faults` when some are given.
std::vector<int> VerdictSessionIndices(const VerdictsBenchOptions& options);

/// The index of the session of `fault` in round `round` (sessions are drawn round-robin over the
/// fault families: even rounds drive, odd rounds pose still, the LiDAR model changes every two
/// rounds in the order ot128, m1, falcon, vlp16, vlp32c, os1-64, avia, mid360); -1 for an
/// unknown fault.
int VerdictSessionIndex(const std::string& fault, int round);

/// Runs the campaign and prints the tables; false with `error` when a session could not be
/// simulated, or when any session was a false accept (an accepted answer beyond 2x the
/// verification tolerance).
bool RunVerdictsBench(const VerdictsBenchOptions& options, std::ostream& out,
                      std::ostream* progress, std::string* error);

}  // namespace calibd::bench
