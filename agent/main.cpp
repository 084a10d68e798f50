// calibd-agent: the on-vehicle LiDAR-camera calibration daemon (see agent/include/calibd/agent/
// agent.hpp; its exit codes are kAgentExit* there, and the integration guide's table).

#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <iostream>
#include <string>

#include "calibd/agent/agent.hpp"
#include "calibd/agent/heap_reserve.hpp"

namespace {

constexpr const char* kHelp =
    R"(calibd-agent: on-vehicle LiDAR-camera extrinsic calibration daemon.

Usage: calibd-agent [--config FILE] [options]

Subscribes to calibd's LCM channels (camera and LiDAR frames, sensor info, calibration requests),
runs a calibration session when one is requested, and publishes status (2 Hz), health (1 Hz) and
a result per session. The current calibration lives in the store directory of the config.

Options:
  --config FILE      agent config (default /etc/calibd/calibd.yaml; documented default in
                     deploy/config/calibd.yaml)
  --lcm-url URL      LCM provider, overrides agent.lcm_url: udpm://... on the vehicle,
                     file:///path/session.lcmlog?speed=0 to replay a recording (same code path)
  --publish-url URL  publish status, health and results there instead of the input bus (needed
                     when replaying, e.g. file:///tmp/out.lcmlog?mode=w)
  --calibrate-now    start a session at once, as a start request would
  --once             exit when the first session has ended (and at the end of a replayed log):
                     exit code 0 verified/updated, 3 rejected, 4 failed, aborted or no session
                     before the log ended, 5 updated but agent.auto_commit could not write the
                     store (the previous calibration stays in use)
  --quiet            no log lines on stderr
  --debug DIR        replays only: what the detectors made of each frame pair, as
                     calibd-calibrate --debug writes it (DIR/pair_NNNNNN.json with every camera
                     board and LiDAR cluster and the gate that stopped it, DIR/pair_NNNNNN.png the
                     range image coloured by gate); DIR is created

Exit codes: 0 stopped by SIGTERM/SIGINT (or --once: verified/updated), 1 could not start (store,
LCM, detectors, UDS secret file, GPIO lines), 2 bad option or config (the message names the key),
3/4/5 see --once. A UDS ECU reset (0x11 01) restarts the program in place (same arguments, same
PID).
)";

}  // namespace

int main(int argc, char** argv) {
  std::string config_path = "/etc/calibd/calibd.yaml";
  calibd::AgentOptions options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kHelp;
      return calibd::kAgentExitOk;
    } else if (arg == "--calibrate-now") {
      options.calibrate_now = true;
    } else if (arg == "--once") {
      options.once = true;
    } else if (arg == "--quiet") {
      options.quiet = true;
    } else if (arg == "--config" && i + 1 < argc) {
      config_path = argv[++i];
    } else if (arg == "--lcm-url" && i + 1 < argc) {
      options.lcm_url = argv[++i];
    } else if (arg == "--publish-url" && i + 1 < argc) {
      options.publish_url = argv[++i];
    } else if (arg == "--debug" && i + 1 < argc) {
      options.debug_dir = argv[++i];
    } else {
      std::cerr << "calibd-agent: unknown option or missing value '" << arg << "' (see --help)\n";
      return calibd::kAgentExitBadConfig;
    }
  }
  calibd::AgentConfig config;
  std::string error;
  if (!calibd::LoadAgentConfig(config_path, &config, &error)) {
    std::cerr << "calibd-agent: " << error << "\n";
    return calibd::kAgentExitBadConfig;
  }
  const std::string url = options.lcm_url.empty() ? config.lcm_url : options.lcm_url;
  if (!options.debug_dir.empty() && url.rfind("file://", 0) != 0) {
    std::cerr << "calibd-agent: --debug writes two files per frame pair: it needs a replayed log "
                 "(--lcm-url file://...), not the vehicle's bus '"
              << url << "'\n";
    return calibd::kAgentExitBadConfig;
  }
  if (config.solve_heap_mb > 0) {
    const auto heap = calibd::ReserveHeap(static_cast<std::size_t>(config.solve_heap_mb) << 20);
    if (!options.quiet)
      std::cerr << "calibd-agent: " << (heap.reserved >> 20) << " MB of heap reserved for the solve"
                << (heap.policy_set ? "" : " (glibc refused part of the heap policy)") << " in "
                << static_cast<int>(heap.ms) << " ms\n";
  }
  int code = calibd::kAgentExitOk;
  {
    calibd::Agent agent(config);
    if (!agent.Init(options, &error)) {
      std::cerr << "calibd-agent: cannot start: " << error << "\n";
      return calibd::kAgentExitCannotRun;
    }
    code = agent.Run();
  }  // the agent is gone (threads joined, sockets and GPIO lines released) before a restart
  if (code == calibd::kAgentExitRestart) {
    // UDS 0x11 ECU reset: the same program with the same arguments, in place (same PID, so a
    // systemd unit sees no exit; a fresh READY=1 follows).
    std::cerr << "calibd-agent: restarting (ECU reset)" << std::endl;
    ::execv("/proc/self/exe", argv);
    std::cerr << "calibd-agent: restart failed: " << std::strerror(errno) << "\n";
    return calibd::kAgentExitCannotRun;
  }
  return code;
}
