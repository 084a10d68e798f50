#include "child_process.hpp"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

namespace calibd::bench {

bool ChildProcess::Start(const std::vector<std::string>& argv, const std::string& log,
                         const std::vector<std::string>& env, std::string* error) {
  Stop();
  if (argv.empty() || ::access(argv[0].c_str(), X_OK) != 0) {
    *error =
        "cannot run '" + (argv.empty() ? std::string() : argv[0]) + "': " + std::strerror(errno);
    return false;
  }
  const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_APPEND | O_CLOEXEC, 0644);
  if (fd < 0) {
    *error = "cannot open " + log + ": " + std::strerror(errno);
    return false;
  }
  // Everything the child needs is built before fork: after it, only async-signal-safe calls.
  std::vector<char*> args;
  for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
  args.push_back(nullptr);
  pid_ = ::fork();
  if (pid_ < 0) {
    *error = std::string("fork: ") + std::strerror(errno);
    ::close(fd);
    return false;
  }
  if (pid_ == 0) {
    for (const std::string& e : env) ::putenv(const_cast<char*>(e.c_str()));
    ::dup2(fd, STDOUT_FILENO);
    ::dup2(fd, STDERR_FILENO);
    ::execv(args[0], args.data());
    ::_exit(127);
  }
  ::close(fd);
  exit_code_ = -1;
  return true;
}

bool ChildProcess::Running() {
  if (pid_ <= 0) return false;
  int status = 0;
  if (::waitpid(pid_, &status, WNOHANG) == 0) return true;
  exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  pid_ = -1;
  return false;
}

int ChildProcess::Stop(int grace_ms) {
  if (!Running()) return exit_code_;
  ::kill(pid_, SIGTERM);
  for (int waited = 0; waited < grace_ms && Running(); waited += 20)
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (Running()) {
    ::kill(pid_, SIGKILL);
    ::waitpid(pid_, nullptr, 0);
    pid_ = -1;
    exit_code_ = -1;
  }
  return exit_code_;
}

ProcSample SampleProcess(pid_t pid) {
  ProcSample s;
  const std::string dir = "/proc/" + std::to_string(pid);
  std::ifstream status(dir + "/status");
  std::string line;
  bool rss = false, threads = false;
  while (std::getline(status, line)) {
    if (line.rfind("VmRSS:", 0) == 0) {
      s.rss_mb = std::strtod(line.c_str() + 6, nullptr) / 1024.0;  // kB
      rss = true;
    } else if (line.rfind("Threads:", 0) == 0) {
      s.threads = std::atoi(line.c_str() + 8);
      threads = true;
    }
  }
  // /proc/<pid>/stat: the command (field 2) is in parentheses and may hold spaces; utime and
  // stime are fields 14 and 15, in clock ticks (proc(5)).
  std::ifstream stat_file(dir + "/stat");
  std::string stat((std::istreambuf_iterator<char>(stat_file)), std::istreambuf_iterator<char>());
  const size_t close = stat.rfind(')');
  bool cpu = false;
  if (close != std::string::npos) {
    std::istringstream fields(stat.substr(close + 2));
    std::string field;
    unsigned long long utime = 0, stime = 0;
    for (int i = 3; i <= 15 && fields >> field; ++i) {
      if (i == 14) utime = std::strtoull(field.c_str(), nullptr, 10);
      if (i == 15) {
        stime = std::strtoull(field.c_str(), nullptr, 10);
        cpu = true;
      }
    }
    s.cpu_s = static_cast<double>(utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
  }
  std::error_code ec;
  for (auto it = std::filesystem::directory_iterator(dir + "/fd", ec);
       !ec && it != std::filesystem::directory_iterator(); it.increment(ec))
    ++s.fds;
  s.ok = rss && threads && cpu && !ec;
  return s;
}

}  // namespace calibd::bench
