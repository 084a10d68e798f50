#include "agent_session.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstring>
#include <filesystem>

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "notify_socket.hpp"
#include "private_network.hpp"
#include "run.hpp"

namespace calibd::bench {

namespace {

std::string Errno(const char* what) { return std::string(what) + ": " + std::strerror(errno); }

void Stop(pid_t pid) {
  ::kill(pid, SIGTERM);
  ::waitpid(pid, nullptr, 0);
}

}  // namespace

bool SimulateDriveLog(const std::string& lidar, unsigned long long seed, int frames,
                      const std::string& dir, DriveLog* drive, std::string* error) {
  sim::SessionOptions so;
  so.seed = seed;
  so.lidar_model = lidar;
  so.image_encoding = "mono8";
  so.trajectory.duration_s = frames / so.trajectory.rate_hz;
  sim::SimOutputs so_out;
  so_out.log_path = (std::filesystem::path(dir) / "drive.lcmlog").string();
  so_out.config_path = (std::filesystem::path(dir) / "calib.yaml").string();
  sim::SimSummary summary;
  if (!sim::RunSimulation(so, so_out, &summary, nullptr, error)) return false;
  drive->log_path = so_out.log_path;
  return ReadWholeFile(so_out.config_path, &drive->calib_yaml, error);
}

std::string BenchAgentYaml(const std::string& calib_yaml, const std::string& store_dir,
                           int target_frames, int max_duration_s) {
  return calib_yaml + "agent:\n  lcm_url: \"" + sim::kPrivateUdpmUrl +
         "\"\n  auto_commit: true\n  store:\n    directory: " + store_dir +
         "\n  target_frames: " + std::to_string(target_frames) +
         "\n  stop_on_coverage: false\n  max_duration_s: " + std::to_string(max_duration_s) + "\n";
}

const char* ResultVerdictName(int8_t verdict) {
  switch (verdict) {
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

bool RunAgentSession(const AgentSessionSpec& spec, AgentSessionRun* run, std::string* error) {
  *run = AgentSessionRun{};
  NotifySocket notify;
  const std::string notify_path =
      (std::filesystem::path(spec.out_log).parent_path() / "notify.sock").string();
  if (!notify.Bind(notify_path, error)) return false;
  const auto t0 = SteadyClock::now();
  const pid_t pid = ::fork();
  if (pid < 0) {
    *error = Errno("fork");
    return false;
  }
  if (pid == 0) {
    ::setenv("NOTIFY_SOCKET", notify_path.c_str(), 1);
    // The agent's log (its solve timings, drops) goes next to its outputs: agent.log.
    const std::string log =
        (std::filesystem::path(spec.out_log).parent_path() / "agent.log").string();
    const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd >= 0) ::dup2(fd, STDERR_FILENO);
    const std::string publish = "file://" + spec.out_log + "?mode=w";
    execl(spec.agent_path.c_str(), spec.agent_path.c_str(), "--once", "--calibrate-now", "--config",
          spec.config_path.c_str(), "--publish-url", publish.c_str(), static_cast<char*>(nullptr));
    _exit(127);
  }
  if (!notify.WaitReady(static_cast<int>(spec.ready_timeout_s * 1000.0))) {
    Stop(pid);
    *error = "calibd-agent did not report READY=1 within " +
             std::to_string(static_cast<int>(spec.ready_timeout_s)) + " s (config " +
             spec.config_path + ")";
    return false;
  }
  run->ready_ms = MsSince(t0);
  notify.Close();
  const std::string agent_log =
      (std::filesystem::path(spec.out_log).parent_path() / "agent.log").string();
  const auto give_up = t0 + std::chrono::duration<double>(spec.ready_timeout_s);
  for (std::string log, ignored; run->detectors_ready_ms < 0.0; ::usleep(10000)) {
    if (ReadWholeFile(agent_log, &log, &ignored) &&
        log.find("LiDAR detector ready") != std::string::npos)
      run->detectors_ready_ms = MsSince(t0);
    else if (SteadyClock::now() > give_up) {
      Stop(pid);
      *error = "calibd-agent's LiDAR detector not ready within " +
               std::to_string(static_cast<int>(spec.ready_timeout_s)) + " s; its log: " + agent_log;
      return false;
    }
  }

  sim::LivePublishOptions live;
  live.log_path = spec.drive_log;
  live.url = spec.lcm_url;
  live.loops = spec.loops;
  live.start_delay_s = 0.5;  // the agent has joined its multicast group when READY; some slack
  if (!sim::PublishLive(live, &run->published, nullptr, error)) {
    Stop(pid);
    return false;
  }
  int status = 0;
  rusage usage{};
  if (::wait4(pid, &status, 0, &usage) != pid) {
    *error = Errno("wait4");
    return false;
  }
  run->wall_s = std::chrono::duration<double>(SteadyClock::now() - t0).count();
  run->exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  run->peak_rss_mb = static_cast<double>(usage.ru_maxrss) / 1024.0;  // ru_maxrss is in KiB
  auto seconds = [](const timeval& tv) {
    return static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
  };
  run->cpu_s = seconds(usage.ru_utime) + seconds(usage.ru_stime);
  std::string read_error;
  if (ReadAgentOutputs(spec.out_log, &run->outputs, &read_error) && run->outputs.results > 0) {
    run->has_result = true;
    run->last_frame_to_result_ms =
        static_cast<double>(run->outputs.last_result.utime - run->published.last_frame_wall_us) *
        1e-3;
  }
  return true;
}

}  // namespace calibd::bench
