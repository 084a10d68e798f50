#pragma once
/// \file
/// A program the benches run beside themselves (the agent, the simulator), and what /proc says
/// about it: resident memory, open file descriptors, threads and CPU time.

#include <sys/types.h>

#include <string>
#include <vector>

namespace calibd::bench {

class ChildProcess {
 public:
  ChildProcess() = default;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;
  ~ChildProcess() { Stop(); }

  /// Runs argv[0] (a path) with `argv`, its stdout and stderr appended to `log`, `env` ("NAME=
  /// value") added to this process's environment. False with `error` when it cannot be started.
  bool Start(const std::vector<std::string>& argv, const std::string& log,
             const std::vector<std::string>& env, std::string* error);
  pid_t pid() const { return pid_; }
  /// Whether it still runs; reaps it (and keeps its exit code) once it has ended.
  bool Running();
  /// Its exit status once ended: the exit code, or -1 when a signal ended it.
  int exit_code() const { return exit_code_; }
  /// SIGTERM, then SIGKILL after `grace_ms`; returns exit_code() (-1 when it had to be killed).
  int Stop(int grace_ms = 10000);

 private:
  pid_t pid_ = -1;
  int exit_code_ = -1;
};

/// One look at a running process in /proc.
struct ProcSample {
  bool ok = false;     ///< false: the process is gone (or /proc unreadable)
  double rss_mb = 0;   ///< VmRSS, MiB
  int fds = 0;         ///< entries of /proc/<pid>/fd
  int threads = 0;     ///< Threads
  double cpu_s = 0.0;  ///< user + system time so far
};
ProcSample SampleProcess(pid_t pid);

}  // namespace calibd::bench
