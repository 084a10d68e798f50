#pragma once
/// \file
/// One calibration session of the real calibd-agent process, fed live: the agent is started
/// with `--once --calibrate-now`, its start-up is timed to its systemd READY=1 (NOTIFY_SOCKET
/// pointed at a socket of ours), then a recorded drive is published over LCM in real time and the
/// agent runs to its exit. Shared by `calibd-bench agent-memory` and `calibd-bench pipeline`.

#include <string>

#include "calibd/drivers/agent_outputs.hpp"
#include "live_publisher.hpp"

namespace calibd::bench {

struct AgentSessionSpec {
  std::string agent_path;   ///< calibd-agent to run
  std::string config_path;  ///< its config (agent: section with lcm_url, store, target_frames...)
  std::string out_log;      ///< where the agent publishes its status/result/health (LCM log);
                            ///< its log lines go to agent.log in the same directory
  std::string drive_log;    ///< the drive to publish (calibd-sim --out)
  std::string lcm_url;      ///< where to publish it (the agent's lcm_url)
  int loops = 1;            ///< times the drive is published (capture times shifted)
  double ready_timeout_s = 30.0;
};

struct AgentSessionRun {
  int exit_code = -1;        ///< the agent's, -1 when it did not exit normally
  double peak_rss_mb = 0.0;  ///< ru_maxrss of the agent process
  double cpu_s = 0.0;        ///< user + system CPU time of the agent process, start to exit
  double wall_s = 0.0;       ///< start to exit
  double ready_ms = -1.0;    ///< start (fork) to READY=1; -1 when it never came
  /// Start (fork) to the LiDAR detector ready (its references are built after READY=1, on the
  /// intake's worker: the agent's log line "LiDAR detector ready"); the drive is published after
  /// it, since the agent ignores frames until then. -1 when it never came.
  double detectors_ready_ms = -1.0;
  /// The result message's time (the agent's wall clock) minus the time the publisher sent the
  /// drive's last frame; meaningful only with has_result.
  double last_frame_to_result_ms = 0.0;
  bool has_result = false;
  sim::LivePublishSummary published;
  AgentOutputs outputs;  ///< what the agent published (zero when its log could not be read)
};

/// A simulated drive as calibd-sim writes it, with raw mono8 images as a camera driver sends them
/// (2.4 GB for 200 pairs at 3840x1920).
struct DriveLog {
  std::string log_path;    ///< the LCM log
  std::string calib_yaml;  ///< the user config the simulator wrote for it
};
/// Simulates the default drive of `lidar` squeezed into `frames` pairs into `dir`.
bool SimulateDriveLog(const std::string& lidar, unsigned long long seed, int frames,
                      const std::string& dir, DriveLog* drive, std::string* error);

/// `calib_yaml` plus the agent section of a bench session on the private network
/// (sim::kPrivateUdpmUrl): auto-commit into `store_dir`, `target_frames` pairs wanted (no
/// early stop on coverage), at most `max_duration_s`.
std::string BenchAgentYaml(const std::string& calib_yaml, const std::string& store_dir,
                           int target_frames, int max_duration_s);

/// "verified", "updated", "rejected" or "none" for calibration_result_t::verdict.
const char* ResultVerdictName(int8_t verdict);

/// Runs the session; false with `error` when the agent could not be started, never became ready,
/// or the drive could not be published (the agent is then stopped).
bool RunAgentSession(const AgentSessionSpec& spec, AgentSessionRun* run, std::string* error);

}  // namespace calibd::bench
