#include "agent_memory_bench.hpp"

#include <unistd.h>

#include <filesystem>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <ostream>

#include "agent_session.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "private_network.hpp"

namespace calibd::bench {

namespace {

struct SessionRun {
  int loops = 0;
  int published = 0;  ///< frame pairs
  AgentSessionRun agent;
};

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

  if (progress) *progress << "agent-memory: simulating " << o.frames << " frame pairs\n";
  DriveLog drive;
  if (!SimulateDriveLog(o.lidar, o.seed, o.frames, dir.string(), &drive, error)) return false;

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
    AgentSessionSpec spec;
    spec.agent_path = o.agent_path;
    spec.config_path = (run_dir / "agent.yaml").string();
    spec.out_log = (run_dir / "out.lcmlog").string();
    spec.drive_log = drive.log_path;
    spec.lcm_url = sim::kPrivateUdpmUrl;
    spec.loops = loops;
    const std::string yaml = BenchAgentYaml(drive.calib_yaml, (run_dir / "store").string(),
                                            max_pairs, run.published / 10 + 10);
    if (!WriteFileAtomic(spec.config_path, yaml, error)) return false;
    if (progress)
      *progress << "agent-memory: session of " << run.published << " frame pairs (drive x " << loops
                << ", " << run.published / 10 << " s at 10 Hz)\n";
    if (!RunAgentSession(spec, &run.agent, error)) return false;
    runs.push_back(run);
  }

  out << "\nAgent peak memory: " << o.lidar << " drive of " << o.frames
      << " frame pairs published live at 10 Hz (udpm, private network namespace), looped;\n"
      << "one session per row, same config (target_frames " << max_pairs
      << "; max_frames and engine.max_solve_frames default: 200), except the time limit that\n"
      << "ends each session 10 s after its stream\n\n";
  out << "| pairs published | camera recv / missing / dropped | LiDAR recv / missing / dropped |"
         " pairs used by the solve | verdict | agent CPU (s) | peak RSS (MB) | vs first |\n"
      << "|---|---|---|---|---|---|---|---|\n";
  nlohmann::json rows = nlohmann::json::array();
  for (const SessionRun& r : runs) {
    const AgentSessionRun& a = r.agent;
    const health_t& h = a.outputs.last_health;
    const char* verdict = a.has_result ? ResultVerdictName(a.outputs.last_result.verdict) : "none";
    const int used = a.has_result ? a.outputs.last_result.frames_used : 0;
    const double ratio = a.peak_rss_mb / runs.front().agent.peak_rss_mb;
    out << "| " << r.published << " | " << h.camera_frames_received << " / "
        << h.camera_frames_missed << " / " << h.camera_frames_dropped << " | "
        << h.lidar_frames_received << " / " << h.lidar_frames_missed << " / "
        << h.lidar_frames_dropped << " | " << used << " | " << verdict << " (exit " << a.exit_code
        << ") | " << std::fixed << std::setprecision(1) << a.cpu_s << " | " << a.peak_rss_mb
        << " | " << std::showpos << (ratio - 1.0) * 100.0 << "%" << std::noshowpos << " |\n";
    rows.push_back({{"pairs_published", r.published},
                    {"camera_received", h.camera_frames_received},
                    {"camera_missed", h.camera_frames_missed},
                    {"camera_dropped", h.camera_frames_dropped},
                    {"lidar_received", h.lidar_frames_received},
                    {"lidar_missed", h.lidar_frames_missed},
                    {"lidar_dropped", h.lidar_frames_dropped},
                    {"pairs_used", used},
                    {"verdict", verdict},
                    {"exit_code", a.exit_code},
                    {"cpu_s", a.cpu_s},
                    {"ready_ms", a.ready_ms},
                    {"peak_rss_mb", a.peak_rss_mb},
                    {"wall_s", a.wall_s}});
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
