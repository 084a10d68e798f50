#include "agent_memory_bench.hpp"

#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <ostream>

#include "calibd/calibration_result_t.hpp"
#include "calibd/drivers/agent_outputs.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/health_t.hpp"
#include "live_publisher.hpp"
#include "private_network.hpp"
#include "run.hpp"

namespace calibd::bench {

namespace {

struct SessionRun {
  int loops = 0;
  int published = 0;  ///< frame pairs
  double peak_rss_mb = 0.0;
  int exit_code = -1;
  health_t health;  ///< the agent's last
  calibration_result_t result;
  bool has_result = false;
  double wall_s = 0.0;
};

// Starts the agent; its pid, or -1.
pid_t StartAgent(const std::string& agent, const std::string& config, const std::string& out_log) {
  const pid_t pid = ::fork();
  if (pid != 0) return pid;
  const std::string publish = "file://" + out_log + "?mode=w";
  execl(agent.c_str(), agent.c_str(), "--quiet", "--once", "--calibrate-now", "--config",
        config.c_str(), "--publish-url", publish.c_str(), static_cast<char*>(nullptr));
  _exit(127);
}

const char* VerdictText(int8_t v) {
  switch (v) {
    case calibration_result_t::VERDICT_VERIFIED:
      return "verified";
    case calibration_result_t::VERDICT_UPDATED:
      return "updated";
    case calibration_result_t::VERDICT_REJECTED:
      return "rejected";
    default:
      return "none";
  }
}

}  // namespace

bool RunAgentMemoryBench(const AgentMemoryBenchOptions& o, std::ostream& out,
                         std::ostream* progress, std::string* error) {
  namespace fs = std::filesystem;
  if (o.agent_path.empty() || !fs::exists(o.agent_path)) {
    if (error) *error = "calibd-agent not found at '" + o.agent_path + "' (use --agent PATH)";
    return false;
  }
  const fs::path dir =
      o.work_dir.empty()
          ? fs::temp_directory_path() / ("calibd-agent-memory-" + std::to_string(::getpid()))
          : fs::path(o.work_dir);
  fs::create_directories(dir);
  if (!sim::EnterPrivateNetwork(error)) return false;

  // One drive with raw mono8 images, as a camera driver sends them (2.4 GB for 200 pairs).
  sim::SessionOptions so;
  so.seed = o.seed;
  so.lidar_model = o.lidar;
  so.image_encoding = "mono8";
  so.trajectory.duration_s = o.frames / so.trajectory.rate_hz;
  sim::SimOutputs so_out;
  so_out.log_path = (dir / "drive.lcmlog").string();
  so_out.config_path = (dir / "calib.yaml").string();
  if (progress) *progress << "agent-memory: simulating " << o.frames << " frame pairs\n";
  sim::SimSummary summary;
  if (!sim::RunSimulation(so, so_out, &summary, nullptr, error)) return false;
  std::string calib_yaml;
  if (!ReadWholeFile(so_out.config_path, &calib_yaml, error)) return false;

  // The same config for every session: the default store (max_frames 200, thinned when a session
  // is longer), every pair wanted.
  int max_loops = 1;
  for (int l : o.loops) max_loops = std::max(max_loops, l);
  const int max_pairs = max_loops * o.frames;

  std::vector<SessionRun> runs;
  for (int loops : o.loops) {
    SessionRun run;
    run.loops = loops;
    run.published = loops * o.frames;
    const fs::path run_dir = dir / ("loops" + std::to_string(loops));
    fs::remove_all(run_dir);
    fs::create_directories(run_dir);
    // The time limit ends a session shorter than max_pairs: 10 s of silence after its stream.
    const int limit_s = run.published / 10 + 10;
    const std::string yaml =
        calib_yaml + "agent:\n  lcm_url: \"" + sim::kPrivateUdpmUrl +
        "\"\n  auto_commit: true\n  store:\n    directory: " + (run_dir / "store").string() +
        "\n  target_frames: " + std::to_string(max_pairs) + "\n  stop_on_coverage: false\n" +
        "  max_duration_s: " + std::to_string(limit_s) + "\n";
    const std::string config = (run_dir / "agent.yaml").string();
    if (!WriteFileAtomic(config, yaml, error)) return false;
    const std::string out_log = (run_dir / "out.lcmlog").string();
    if (progress)
      *progress << "agent-memory: session of " << run.published << " frame pairs (drive x " << loops
                << ", " << run.published / 10 << " s at 10 Hz)\n";
    const auto t0 = std::chrono::steady_clock::now();
    const pid_t pid = StartAgent(o.agent_path, config, out_log);
    if (pid < 0) {
      if (error) *error = std::string("fork: ") + std::strerror(errno);
      return false;
    }
    sim::LivePublishOptions live;
    live.log_path = so_out.log_path;
    live.url = sim::kPrivateUdpmUrl;
    live.loops = loops;
    live.start_delay_s = 2.0;
    sim::LivePublishSummary published;
    if (!sim::PublishLive(live, &published, nullptr, error)) {
      ::kill(pid, SIGTERM);
      ::waitpid(pid, nullptr, 0);
      return false;
    }
    int status = 0;
    rusage usage{};
    if (::wait4(pid, &status, 0, &usage) != pid) {
      if (error) *error = std::string("wait4: ") + std::strerror(errno);
      return false;
    }
    run.wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    run.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    run.peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB
    AgentOutputs outputs;
    std::string read_error;
    if (ReadAgentOutputs(out_log, &outputs, &read_error)) {
      run.health = outputs.last_health;
      run.has_result = outputs.results > 0;
      run.result = outputs.last_result;
    }
    runs.push_back(run);
  }

  out << "\nAgent peak memory: " << o.lidar << " drive of " << o.frames
      << " frame pairs published live at 10 Hz (udpm, private network namespace), looped;\n"
      << "one session per row, same config (target_frames " << max_pairs
      << "; max_frames and engine.max_solve_frames default: 200), except the time limit that\n"
      << "ends each session 10 s after its stream\n\n";
  out << "| pairs published | camera recv / missing / dropped | LiDAR recv / missing / dropped |"
         " pairs used by the solve | verdict | peak RSS (MB) | vs first |\n"
      << "|---|---|---|---|---|---|---|\n";
  nlohmann::json rows = nlohmann::json::array();
  for (const SessionRun& r : runs) {
    const double ratio = r.peak_rss_mb / runs.front().peak_rss_mb;
    out << "| " << r.published << " | " << r.health.camera_frames_received << " / "
        << r.health.camera_frames_missed << " / " << r.health.camera_frames_dropped << " | "
        << r.health.lidar_frames_received << " / " << r.health.lidar_frames_missed << " / "
        << r.health.lidar_frames_dropped << " | " << (r.has_result ? r.result.frames_used : 0)
        << " | " << (r.has_result ? VerdictText(r.result.verdict) : "none") << " (exit "
        << r.exit_code << ") | " << std::fixed << std::setprecision(1) << r.peak_rss_mb << " | "
        << std::showpos << std::setprecision(1) << (ratio - 1.0) * 100.0 << "%" << std::noshowpos
        << " |\n";
    rows.push_back({{"pairs_published", r.published},
                    {"camera_received", r.health.camera_frames_received},
                    {"camera_missed", r.health.camera_frames_missed},
                    {"camera_dropped", r.health.camera_frames_dropped},
                    {"lidar_received", r.health.lidar_frames_received},
                    {"lidar_missed", r.health.lidar_frames_missed},
                    {"lidar_dropped", r.health.lidar_frames_dropped},
                    {"pairs_used", r.has_result ? r.result.frames_used : 0},
                    {"verdict", r.has_result ? VerdictText(r.result.verdict) : "none"},
                    {"exit_code", r.exit_code},
                    {"peak_rss_mb", r.peak_rss_mb},
                    {"wall_s", r.wall_s}});
  }
  out << "\nTarget: peak RSS of the sessions within 5% of each other.\n";
  if (!o.json_path.empty() &&
      !WriteFileAtomic(
          o.json_path,
          nlohmann::json{{"lidar", o.lidar}, {"frames", o.frames}, {"runs", rows}}.dump(2) + "\n",
          error))
    return false;
  if (o.work_dir.empty()) fs::remove_all(dir);
  return true;
}

}  // namespace calibd::bench
