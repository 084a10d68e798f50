#pragma once
/// \file
/// `calibd-bench soak`: one calibd-agent running for N minutes through back-to-back workshop
/// sessions, the way a workshop's tester and the car's sensors would drive it.
///  - calibd-sim publishes a recorded drive over LCM, looping, for the whole run;
///  - a tester over CAN (UDS on the kernel's ISO-TP, calibd-tester's client in this process)
///    runs each session: unlock, calibrate to its verdict, commit, restore the reference (so the
///    next session starts from the prior again and ends `updated` again);
///  - once a second, the agent's resident memory, open file descriptors, threads and CPU time are
///    read from /proc.
/// The agent is seeded with the drive's prior as its current and reference calibration. Each
/// session is a row: its verdict, time, the agent's CPU time, its peak and final RSS, fds and
/// threads. The run fails when a session fails, the agent dies or does not stop cleanly, or it
/// leaks: fds or threads at the end of a session above the first session's, RSS above the first
/// session's end by more than max_rss_growth_mb or, in runs of 16 sessions or more, growing over
/// the second half by more than 1 MB; the store holding more files than its configured history.
/// Needs a CAN interface with can-isotp (tests/vm/soak.sh runs it in the test VM).

#include <iosfwd>
#include <string>

namespace calibd::bench {

struct SoakBenchOptions {
  double minutes = 2.0;    ///< sessions start until this much time has passed
  std::string agent_path;  ///< calibd-agent to run
  std::string sim_path;    ///< calibd-sim that publishes the drive
  std::string drive_log;   ///< the drive (calibd-sim --out): required
  std::string calib_yaml;  ///< its calibration config (calibd-sim --config-out): required
  std::string interface = "vcan0";
  /// Where the drive is published and the agent listens (the agent's lcm_url).
  std::string lcm_url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216";
  double speed = 1.0;          ///< replay speed of the drive
  int min_frames = 60;         ///< the agent's agent.min_frames
  int min_distance_bins = -1;  ///< the agent's agent.min_distance_bins (-1: the agent's default)
  int max_duration_s = 150;    ///< the agent's agent.max_duration_s, and the tester's limit
  /// The agent's engine.verdict.max_translation_bound_m (0: the agent's default).
  double max_translation_bound_m = 0.0;
  /// The agent's engine.verdict.max_rotation_bound_deg (0: the agent's default).
  double max_rotation_bound_deg = 0.0;
  int p2_ms = 2000;  ///< the tester's P2 (an emulated guest answers slowly)
  /// Allowed RSS growth after the first session: the heap settles over the first sessions
  /// (+7.7 MB in the first 8 of a 30-minute run in the VM, then flat).
  double max_rss_growth_mb = 16.0;
  std::string work_dir;   ///< configs, store, logs ("" = a temporary directory, kept)
  std::string json_path;  ///< also write the figures as JSON
};

/// Runs the soak; prints the table and the checks on `out`, progress on `progress`. False with
/// `error` when it could not run (missing files, no CAN interface, the agent not starting) or
/// when a check failed (error names it).
bool RunSoakBench(const SoakBenchOptions& options, std::ostream& out, std::ostream* progress,
                  std::string* error);

}  // namespace calibd::bench
