#include "soak_bench.hpp"

#include <net/if.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <mutex>
#include <nlohmann/json.hpp>
#include <ostream>
#include <sstream>
#include <thread>
#include <vector>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/config_file.hpp"
#include "child_process.hpp"
#include "notify_socket.hpp"
#include "session.hpp"
#include "tester_cli.hpp"

namespace calibd::bench {

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

/// The result of one calibd-tester command run in this process.
struct TesterRun {
  int code = -1;
  std::string out, err;
};

/// Seconds the first session waits for the agent to hear LiDAR and camera.
constexpr int kStreamWaitS = 30;

/// The calibrate routine was refused for its preconditions (ISO 14229-1 NRC 0x22), which
/// include both sensors sending.
bool StreamsNotHeard(const TesterRun& r) {
  return r.code != 0 && r.err.find("conditionsNotCorrect") != std::string::npos;
}

/// The figures of one session, and what /proc said about the agent meanwhile.
struct SoakSession {
  int index = 0;
  double start_s = 0.0, seconds = 0.0;  ///< since the soak's start; the session's length
  std::string verdict = "none";         ///< the routine's verdict ("updated" expected)
  std::string failure;                  ///< empty when every step of the session went through
  double cpu_s = 0.0;                   ///< the agent's CPU time during the session
  double peak_rss_mb = 0.0;
  ProcSample end;                         ///< the agent after its session
  int store_files = 0, export_files = 0;  ///< in the store directory, in its export/ folder
};

/// Samples the agent once a second on a thread of its own, keeping the peak RSS since the last
/// TakePeak() and every sample's (time, RSS) for the JSON.
class Sampler {
 public:
  explicit Sampler(pid_t pid) : pid_(pid) {}
  ~Sampler() { Stop(); }
  void Start(Clock::time_point t0) {
    t0_ = t0;
    thread_ = std::thread([this] { Loop(); });
  }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
  }
  double TakePeak() {
    std::lock_guard<std::mutex> lock(mutex_);
    const double peak = peak_rss_mb_;
    peak_rss_mb_ = 0.0;
    return peak;
  }
  nlohmann::json Samples() {
    std::lock_guard<std::mutex> lock(mutex_);
    return samples_;
  }

 private:
  void Loop() {
    while (!stop_) {
      const ProcSample s = SampleProcess(pid_);
      if (s.ok) {
        std::lock_guard<std::mutex> lock(mutex_);
        peak_rss_mb_ = std::max(peak_rss_mb_, s.rss_mb);
        samples_.push_back({{"t_s", SecondsSince(t0_)},
                            {"rss_mb", s.rss_mb},
                            {"fds", s.fds},
                            {"threads", s.threads},
                            {"cpu_s", s.cpu_s}});
      }
      for (int i = 0; i < 10 && !stop_; ++i)
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
    }
  }

  pid_t pid_;
  Clock::time_point t0_;
  std::thread thread_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  double peak_rss_mb_ = 0.0;
  nlohmann::json samples_ = nlohmann::json::array();
};

class Soak {
 public:
  Soak(const SoakBenchOptions& o, std::ostream& out, std::ostream* progress)
      : o_(o), out_(out), progress_(progress) {}

  bool Run(std::string* error) {
    if (!Prepare(error) || !StartProcesses(error)) return false;
    const Clock::time_point t0 = Clock::now();
    Sampler sampler(agent_.pid());
    sampler.Start(t0);
    const ProcSample ready = SampleProcess(agent_.pid());
    Progress("soak: agent ready (RSS " + Mb(ready.rss_mb) + " MB, " + std::to_string(ready.fds) +
             " fds, " + std::to_string(ready.threads) + " threads); sessions for " +
             Fixed(o_.minutes, 1) + " min");
    sampler.TakePeak();
    while (sessions_.empty() || SecondsSince(t0) < o_.minutes * 60.0) {
      if (!agent_.Running() || !sim_.Running()) break;
      SoakSession s = RunSession(static_cast<int>(sessions_.size()) + 1, t0);
      s.peak_rss_mb = std::max(sampler.TakePeak(), s.end.rss_mb);
      sessions_.push_back(s);
      Progress("soak: session " + std::to_string(s.index) + " " + s.verdict + " in " +
               Fixed(s.seconds, 1) + " s, RSS " + Mb(s.end.rss_mb) + " MB, " +
               std::to_string(s.end.fds) + " fds" + (s.failure.empty() ? "" : ": " + s.failure));
      if (!s.failure.empty()) break;
    }
    const double wall_s = SecondsSince(t0);
    sampler.Stop();
    const bool agent_alive = agent_.Running();
    const int agent_exit = agent_.Stop();
    sim_.Stop();
    PrintTable(ready, wall_s);
    const bool passed = Check(agent_alive, agent_exit, error);
    if (!o_.json_path.empty()) {
      std::string json_error;
      if (!WriteFileAtomic(o_.json_path, Json(ready, wall_s, sampler.Samples(), passed).dump(2),
                           &json_error)) {
        if (error->empty()) *error = json_error;
        return false;
      }
    }
    return passed;
  }

 private:
  /// Files, the CAN interface, the work directory: the agent's config, secret and seeded store.
  bool Prepare(std::string* error) {
    for (const auto& [what, path] :
         {std::pair<const char*, std::string>{"calibd-agent (--agent)", o_.agent_path},
          {"calibd-sim (--sim)", o_.sim_path},
          {"the drive (--drive)", o_.drive_log},
          {"its calibration config (--calib-yaml)", o_.calib_yaml}}) {
      if (path.empty() || !fs::exists(path)) {
        *error = std::string(what) + " not found: '" + path + "'";
        return false;
      }
    }
    if (::if_nametoindex(o_.interface.c_str()) == 0) {
      *error = "no CAN interface '" + o_.interface +
               "' here: the soak needs SocketCAN with can-isotp (tests/vm/soak.sh runs it in the "
               "test VM)";
      return false;
    }
    dir_ = o_.work_dir.empty()
               ? fs::temp_directory_path() / ("calibd-soak-" + std::to_string(::getpid()))
               : fs::path(o_.work_dir);
    std::error_code ec;
    fs::remove_all(dir_ / "store", ec);
    fs::remove_all(dir_ / "uds", ec);
    fs::create_directories(dir_ / "uds", ec);
    if (ec) {
      *error = "cannot create " + (dir_ / "uds").string() + ": " + ec.message();
      return false;
    }
    // The secret as the agent requires it: owned by its user, mode 0600.
    const std::string secret = "soak-secret-of-this-vehicle-0123456789";
    if (!WriteFileAtomic(Path("secret"), secret, error)) return false;
    fs::permissions(Path("secret"), fs::perms::owner_read | fs::perms::owner_write, ec);
    std::string calib;
    if (!ReadWholeFile(o_.calib_yaml, &calib, error) || !SeedStore(error)) return false;
    const std::string yaml = calib + "agent:\n  lcm_url: \"" + o_.lcm_url +
                             "\"\n  software_version: calibd-soak\n" +
                             "  store:\n    directory: " + Path("store") +
                             "\n    keep_previous: " + std::to_string(kKeepPrevious) +
                             "\n  min_frames: " + std::to_string(o_.min_frames) +
                             (o_.min_distance_bins >= 0
                                  ? "\n  min_distance_bins: " + std::to_string(o_.min_distance_bins)
                                  : std::string()) +
                             "\n  max_duration_s: " + std::to_string(o_.max_duration_s) +
                             "\n  can:\n    enabled: true\n    interface: " + o_.interface +
                             "\n  uds:\n    secret_file: " + Path("secret") +
                             "\n    state_dir: " + Path("uds") + "\n" + EngineYaml();
    return WriteFileAtomic(Path("agent.yaml"), yaml, error);
  }

  /// The engine section of the agent's config: the tolerances given, none for the defaults.
  std::string EngineYaml() const {
    std::string verdict;
    if (o_.max_translation_bound_m > 0.0)
      verdict +=
          "    max_translation_bound_m: " + std::to_string(o_.max_translation_bound_m) + "\n";
    if (o_.max_rotation_bound_deg > 0.0)
      verdict += "    max_rotation_bound_deg: " + std::to_string(o_.max_rotation_bound_deg) + "\n";
    return verdict.empty() ? verdict : "engine:\n  verdict:\n" + verdict;
  }

  /// The drive's prior as the current and the reference calibration, for the simulator's sensor
  /// serials: each session's restore-reference puts the prior back.
  bool SeedStore(std::string* error) {
    CalibConfig config;
    if (!LoadConfigFile(o_.calib_yaml, &config, error)) return false;
    CalibrationStoreConfig store_config;
    store_config.directory = Path("store");
    store_config.keep_previous = kKeepPrevious;
    CalibrationStore store;
    if (!store.Open(store_config, error)) return false;
    const sim::SessionOptions sim_defaults;
    StoredCalibration prior;
    prior.created_unix_s = static_cast<int64_t>(std::time(nullptr));
    prior.T_camera_lidar = config.prior_T_camera_lidar;
    prior.lidar_serial = sim_defaults.lidar_serial;
    prior.camera_serial = sim_defaults.camera_serial;
    prior.source = "factory";
    prior.verdict = "end_of_line";
    return store.SetReference(prior, error) && store.Commit(prior, error);
  }

  bool StartProcesses(std::string* error) {
    // Enough loops of the drive for the whole run and the last session (the simulator stops
    // with the soak).
    const std::vector<std::string> sim_args{
        o_.sim_path, "--replay", o_.drive_log,       "--publish-url", o_.lcm_url, "--loops",
        "100000",    "--speed",  Fixed(o_.speed, 2), "--start-delay", "0"};
    if (!sim_.Start(sim_args, Path("sim.log"), {}, error)) return false;
    NotifySocket notify;
    if (!notify.Bind(Path("notify.sock"), error)) return false;
    const Clock::time_point spawn = Clock::now();
    if (!agent_.Start({o_.agent_path, "--config", Path("agent.yaml")}, Path("agent.log"),
                      {"NOTIFY_SOCKET=" + Path("notify.sock")}, error))
      return false;
    if (!notify.WaitReady(90000)) {
      *error = "calibd-agent did not report READY=1 within 90 s; its log: " + Path("agent.log");
      return false;
    }
    notify.Close();
    // Then its first UDS answer (the emulated guest can take seconds to serve the first one).
    TesterRun r;
    for (int attempt = 0; attempt < 10 && r.code != 0; ++attempt) {
      r = Tester({"read", "F195"});
      if (r.code != 0) std::this_thread::sleep_for(std::chrono::milliseconds(500));
    }
    if (r.code != 0) {
      *error = "no UDS answer from calibd-agent on " + o_.interface + ": " + r.err;
      return false;
    }
    Progress("soak: agent answering on " + o_.interface + " " + Fixed(SecondsSince(spawn), 1) +
             " s after its start");
    return true;
  }

  SoakSession RunSession(int index, Clock::time_point t0) {
    SoakSession s;
    s.index = index;
    s.start_s = SecondsSince(t0);
    const double cpu0 = SampleProcess(agent_.pid()).cpu_s;
    TesterRun r = Tester({"--secret", Path("secret"), "calibrate", "--max-duration",
                          std::to_string(o_.max_duration_s)});
    // The agent answers UDS before it has heard both sensors when the simulator is slow to
    // start (a loaded emulated guest); the first session waits for the streams, later ones do
    // not, so a stream that stops during the soak still fails it.
    for (int wait = 0; index == 1 && wait < kStreamWaitS && StreamsNotHeard(r); ++wait) {
      std::this_thread::sleep_for(std::chrono::seconds(1));
      r = Tester({"--secret", Path("secret"), "calibrate", "--max-duration",
                  std::to_string(o_.max_duration_s)});
    }
    const size_t at = r.out.find("verdict: ");
    if (at != std::string::npos) s.verdict = r.out.substr(at + 9, r.out.find('\n', at) - at - 9);
    if (r.code != 0 || s.verdict != "updated") {
      s.failure =
          "calibrate: exit " + std::to_string(r.code) + ", verdict " + s.verdict + " " + r.err;
    } else {
      const char* step = "commit";
      r = Tester({"--secret", Path("secret"), step});
      if (r.code == 0) {
        step = "restore-reference";
        r = Tester({"--secret", Path("secret"), step});
      }
      if (r.code != 0)
        s.failure = std::string(step) + ": exit " + std::to_string(r.code) + " " + r.out + r.err;
    }
    s.seconds = SecondsSince(t0) - s.start_s;
    s.end = SampleProcess(agent_.pid());
    s.cpu_s = s.end.cpu_s - cpu0;
    std::error_code ec;
    for (auto it = fs::recursive_directory_iterator(Path("store"), ec);
         !ec && it != fs::recursive_directory_iterator(); it.increment(ec)) {
      if (!it->is_regular_file()) continue;
      const bool exported = it->path().parent_path().filename() == "export";
      (exported ? s.export_files : s.store_files) += 1;
    }
    if (!s.end.ok && s.failure.empty()) s.failure = "the agent is gone";
    return s;
  }

  /// calibd-tester's command line, run in this process over the real CAN interface.
  TesterRun Tester(const std::vector<std::string>& command) {
    std::vector<std::string> args{"--interface", o_.interface, "--p2-ms", std::to_string(o_.p2_ms),
                                  "--quiet"};
    args.insert(args.end(), command.begin(), command.end());
    tester::TesterOptions options;
    bool help = false;
    TesterRun run;
    if (!tester::ParseTesterArgs(args, &options, &help, &run.err)) return run;
    std::ostringstream out, err;
    run.code = tester::RunTester(options, out, err);
    run.out = out.str();
    run.err = err.str();
    return run;
  }

  void PrintTable(const ProcSample& ready, double wall_s) {
    out_
        << "\nSoak: calibd-agent for " << Fixed(wall_s / 60.0, 1) << " min, " << sessions_.size()
        << " workshop sessions over CAN ("
        << o_.interface << ", UDS on ISO-TP): unlock, calibrate, commit, restore-reference; the drive "
        << o_.drive_log << " replayed over LCM at speed " << Fixed(o_.speed, 2) << "\n"
        << "agent ready: RSS " << Mb(ready.rss_mb) << " MB, " << ready.fds << " fds, "
        << ready.threads << " threads\n\n";
    out_ << " session  start s  length s  verdict   agent CPU s  peak RSS MB  end RSS MB  fds  "
            "threads  store  result\n";
    for (const SoakSession& s : sessions_) {
      out_ << std::setw(8) << s.index << std::setw(9) << Fixed(s.start_s, 0) << std::setw(10)
           << Fixed(s.seconds, 1) << "  " << std::left << std::setw(8) << s.verdict << std::right
           << std::setw(13) << Fixed(s.cpu_s, 1) << std::setw(13) << Mb(s.peak_rss_mb)
           << std::setw(12) << Mb(s.end.rss_mb) << std::setw(5) << s.end.fds << std::setw(9)
           << s.end.threads << std::setw(7) << s.store_files << "  "
           << (s.failure.empty() ? "ok" : s.failure) << "\n";
    }
  }

  /// The pass/fail checks, each printed; false with `error` naming the first that failed.
  bool Check(bool agent_alive, int agent_exit, std::string* error) {
    std::vector<std::string> failed;
    auto check = [&](bool ok, const std::string& what) {
      out_ << (ok ? "  ok    " : "  FAIL  ") << what << "\n";
      if (!ok) failed.push_back(what);
    };
    out_ << "\nChecks:\n";
    int failed_sessions = 0;
    for (const SoakSession& s : sessions_) failed_sessions += s.failure.empty() ? 0 : 1;
    check(!sessions_.empty() && failed_sessions == 0,
          std::to_string(sessions_.size() - static_cast<size_t>(failed_sessions)) + " of " +
              std::to_string(sessions_.size()) + " sessions updated, committed and restored");
    check(agent_alive, "calibd-agent running to the end");
    check(agent_exit == 0, "calibd-agent exit code on SIGTERM: " + std::to_string(agent_exit));
    if (!sessions_.empty()) {
      const SoakSession& first = sessions_.front();
      int max_fds = 0, max_threads = 0, max_store = 0, max_export = 0;
      double max_rss = 0.0;
      for (const SoakSession& s : sessions_) {
        max_fds = std::max(max_fds, s.end.fds);
        max_threads = std::max(max_threads, s.end.threads);
        max_rss = std::max(max_rss, s.end.rss_mb);
        max_store = std::max(max_store, s.store_files);
        max_export = std::max(max_export, s.export_files);
      }
      check(max_fds <= first.end.fds, "open fds after each session: at most " +
                                          std::to_string(max_fds) + ", after the first " +
                                          std::to_string(first.end.fds));
      check(max_threads <= first.end.threads,
            "threads after each session: at most " + std::to_string(max_threads) +
                ", after the first " + std::to_string(first.end.threads));
      check(max_rss - first.end.rss_mb <= o_.max_rss_growth_mb,
            "RSS after each session: at most " + Mb(max_rss) + " MB, after the first " +
                Mb(first.end.rss_mb) + " MB (growth " + Mb(max_rss - first.end.rss_mb) +
                " MB, limit " + Mb(o_.max_rss_growth_mb) + ")");
      if (sessions_.size() >= 3) {
        out_ << "        RSS trend over sessions 2.." << sessions_.size() << ": "
             << Fixed(RssSlope() * 1024.0, 0) << " kB per session\n";
      }
      // The heap settles in the first sessions (one arena, never trimmed: its high-water mark
      // creeps up while the solves' allocations find their places); a leak keeps growing. From
      // kSettledSessions on, the second half of the run must be flat.
      if (sessions_.size() >= kSettledSessions) {
        const size_t half = sessions_.size() / 2;
        const double at_half = sessions_[half - 1].end.rss_mb;
        double late_max = 0.0;
        for (size_t i = half; i < sessions_.size(); ++i)
          late_max = std::max(late_max, sessions_[i].end.rss_mb);
        check(late_max - at_half <= kFlatMb,
              "RSS over the second half (sessions " + std::to_string(half + 1) + ".." +
                  std::to_string(sessions_.size()) + "): at most " + Mb(late_max) +
                  " MB, after session " + std::to_string(half) + " " + Mb(at_half) +
                  " MB (limit +" + Mb(kFlatMb) + ")");
      }
      // current.json, reference.json and the current plus keep_previous versions in history/;
      // export/ (the calibration in other tools' formats) is rewritten, never added to.
      const int store_limit = 2 + 1 + kKeepPrevious;
      check(max_store <= store_limit, "store files after each session: at most " +
                                          std::to_string(max_store) + " (current, reference, " +
                                          "history: limit " + std::to_string(store_limit) + ")");
      check(max_export == first.export_files,
            "export files after each session: at most " + std::to_string(max_export) +
                ", after the first " + std::to_string(first.export_files));
    }
    if (failed.empty()) return true;
    *error = "soak failed: " + failed.front();
    return false;
  }

  /// Least-squares slope of the end-of-session RSS over sessions 2.. (MB per session).
  double RssSlope() const {
    double n = 0, sx = 0, sy = 0, sxx = 0, sxy = 0;
    for (size_t i = 1; i < sessions_.size(); ++i) {
      const double x = static_cast<double>(i), y = sessions_[i].end.rss_mb;
      n += 1;
      sx += x;
      sy += y;
      sxx += x * x;
      sxy += x * y;
    }
    const double d = n * sxx - sx * sx;
    return d > 0 ? (n * sxy - sx * sy) / d : 0.0;
  }

  nlohmann::json Json(const ProcSample& ready, double wall_s, nlohmann::json samples,
                      bool passed) const {
    nlohmann::json j{
        {"minutes", wall_s / 60.0},
        {"passed", passed},
        {"ready", {{"rss_mb", ready.rss_mb}, {"fds", ready.fds}, {"threads", ready.threads}}},
        {"samples", std::move(samples)}};
    j["sessions"] = nlohmann::json::array();
    for (const SoakSession& s : sessions_) {
      j["sessions"].push_back({{"index", s.index},
                               {"start_s", s.start_s},
                               {"seconds", s.seconds},
                               {"verdict", s.verdict},
                               {"failure", s.failure},
                               {"cpu_s", s.cpu_s},
                               {"peak_rss_mb", s.peak_rss_mb},
                               {"end_rss_mb", s.end.rss_mb},
                               {"end_fds", s.end.fds},
                               {"end_threads", s.end.threads},
                               {"store_files", s.store_files},
                               {"export_files", s.export_files}});
    }
    return j;
  }

  std::string Path(const std::string& name) const { return (dir_ / name).string(); }
  void Progress(const std::string& line) {
    if (progress_ != nullptr) *progress_ << line << std::endl;
  }
  static std::string Fixed(double v, int digits) {
    std::ostringstream s;
    s << std::fixed << std::setprecision(digits) << v;
    return s.str();
  }
  static std::string Mb(double v) { return Fixed(v, 1); }

  static constexpr int kKeepPrevious = 5;
  static constexpr size_t kSettledSessions = 16;
  static constexpr double kFlatMb = 1.0;
  const SoakBenchOptions& o_;
  std::ostream& out_;
  std::ostream* progress_;
  fs::path dir_;
  ChildProcess sim_, agent_;
  std::vector<SoakSession> sessions_;
};

}  // namespace

bool RunSoakBench(const SoakBenchOptions& options, std::ostream& out, std::ostream* progress,
                  std::string* error) {
  Soak soak(options, out, progress);
  return soak.Run(error);
}

}  // namespace calibd::bench
