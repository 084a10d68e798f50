// systemd notification: SystemdNotifier against a real NOTIFY_SOCKET (an
// AF_UNIX datagram socket standing in for systemd), then the real calibd-agent process: READY=1,
// watchdog pings within the interval systemd asks for, STOPPING=1 and exit code 0 on SIGTERM.

#include <fcntl.h>
#include <poll.h>
#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstddef>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <optional>
#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/systemd_notify.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

using Clock = std::chrono::steady_clock;

// Sets environment variables for one test and restores the previous values at scope exit.
class ScopedEnv {
 public:
  ~ScopedEnv() {
    for (auto it = saved_.rbegin(); it != saved_.rend(); ++it) {
      if (it->second)
        ::setenv(it->first.c_str(), it->second->c_str(), 1);
      else
        ::unsetenv(it->first.c_str());
    }
  }
  void Set(const std::string& name, const std::string& value) {
    Save(name);
    ::setenv(name.c_str(), value.c_str(), 1);
  }
  void Unset(const std::string& name) {
    Save(name);
    ::unsetenv(name.c_str());
  }

 private:
  void Save(const std::string& name) {
    const char* v = std::getenv(name.c_str());
    saved_.emplace_back(name, v ? std::optional<std::string>(v) : std::nullopt);
  }
  std::vector<std::pair<std::string, std::optional<std::string>>> saved_;
};

// What systemd listens on: an AF_UNIX datagram socket at a path, or in the abstract namespace
// when the name starts with '@' (NOTIFY_SOCKET accepts both).
class NotifySocket {
 public:
  explicit NotifySocket(const std::string& name) : name_(name) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    if (fd_ < 0 || name.size() >= sizeof(addr.sun_path)) return;
    std::memcpy(addr.sun_path, name.data(), name.size());
    if (name[0] == '@') addr.sun_path[0] = '\0';
    const auto len = static_cast<socklen_t>(offsetof(sockaddr_un, sun_path) + name.size());
    bound_ = ::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), len) == 0;
  }
  ~NotifySocket() {
    if (fd_ >= 0) ::close(fd_);
    if (bound_ && name_[0] != '@') ::unlink(name_.c_str());
  }
  bool bound() const { return bound_; }
  /// The next datagram, or nothing within `timeout_ms`.
  std::optional<std::string> Receive(int timeout_ms) {
    pollfd p{fd_, POLLIN, 0};
    if (::poll(&p, 1, timeout_ms) <= 0) return std::nullopt;
    char buf[4096];
    const ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
    if (n < 0) return std::nullopt;
    return std::string(buf, static_cast<size_t>(n));
  }

 private:
  std::string name_;
  int fd_ = -1;
  bool bound_ = false;
};

TEST(SystemdNotifierTest, IsANoOpWithoutNotifySocket) {
  ScopedEnv env;
  env.Unset("NOTIFY_SOCKET");
  env.Set("WATCHDOG_USEC", "400000");  // a watchdog without a socket to ping: none
  SystemdNotifier notifier;
  EXPECT_FALSE(notifier.enabled());
  EXPECT_EQ(notifier.watchdog_interval_us(), 0u);
  EXPECT_FALSE(notifier.Ready());
  EXPECT_FALSE(notifier.Status("idle"));
  EXPECT_FALSE(notifier.WatchdogPing());
  EXPECT_FALSE(notifier.Stopping());
}

TEST(SystemdNotifierTest, SendsTheProtocolsDatagrams) {
  testing::TempDir dir;
  NotifySocket socket(dir.file("notify.sock"));
  ASSERT_TRUE(socket.bound()) << dir.file("notify.sock");
  ScopedEnv env;
  env.Set("NOTIFY_SOCKET", dir.file("notify.sock"));
  env.Unset("WATCHDOG_USEC");
  SystemdNotifier notifier;
  EXPECT_TRUE(notifier.enabled());
  EXPECT_EQ(notifier.watchdog_interval_us(), 0u);

  EXPECT_TRUE(notifier.Ready());
  EXPECT_EQ(socket.Receive(1000), "READY=1");
  EXPECT_TRUE(notifier.Status("session 1: collecting 40%"));
  EXPECT_EQ(socket.Receive(1000), "STATUS=session 1: collecting 40%");
  EXPECT_TRUE(notifier.WatchdogPing());
  EXPECT_EQ(socket.Receive(1000), "WATCHDOG=1");
  EXPECT_TRUE(notifier.Stopping());
  EXPECT_EQ(socket.Receive(1000), "STOPPING=1");

  // STATUS= is one line (assignments are newline-separated) and cut at kMaxStatusChars.
  EXPECT_TRUE(notifier.Status("failed\nREADY=1"));
  EXPECT_EQ(socket.Receive(1000), "STATUS=failed READY=1");
  const std::string long_text(SystemdNotifier::kMaxStatusChars + 50, 'x');
  EXPECT_TRUE(notifier.Status(long_text));
  EXPECT_EQ(socket.Receive(1000), "STATUS=" + std::string(SystemdNotifier::kMaxStatusChars, 'x'));
  EXPECT_TRUE(notifier.Status("idle"));  // a shorter text after a longer one: no leftovers
  EXPECT_EQ(socket.Receive(1000), "STATUS=idle");
  EXPECT_EQ(socket.Receive(100), std::nullopt) << "one datagram per call";
}

TEST(SystemdNotifierTest, SendsToAnAbstractSocket) {
  const std::string name = "@calibd-test-notify-" + std::to_string(::getpid());
  NotifySocket socket(name);
  ASSERT_TRUE(socket.bound());
  ScopedEnv env;
  env.Set("NOTIFY_SOCKET", name);
  SystemdNotifier notifier;
  EXPECT_TRUE(notifier.Ready());
  EXPECT_EQ(socket.Receive(1000), "READY=1");
}

TEST(SystemdNotifierTest, WatchdogIntervalFromTheEnvironment) {
  testing::TempDir dir;
  ScopedEnv env;
  env.Set("NOTIFY_SOCKET", dir.file("notify.sock"));
  env.Unset("WATCHDOG_PID");
  env.Set("WATCHDOG_USEC", "400000");
  EXPECT_EQ(SystemdNotifier().watchdog_interval_us(), 400000u);
  env.Set("WATCHDOG_PID", std::to_string(::getpid()));
  EXPECT_EQ(SystemdNotifier().watchdog_interval_us(), 400000u);
  // sd_watchdog_enabled(3): the pings are another process's job.
  env.Set("WATCHDOG_PID", std::to_string(::getpid() + 1));
  EXPECT_EQ(SystemdNotifier().watchdog_interval_us(), 0u);
  env.Unset("WATCHDOG_PID");
  env.Set("WATCHDOG_USEC", "not-a-number");
  EXPECT_EQ(SystemdNotifier().watchdog_interval_us(), 0u);
  env.Unset("WATCHDOG_USEC");
  EXPECT_EQ(SystemdNotifier().watchdog_interval_us(), 0u);
}

// The real calibd-agent with the shipped default config (store moved to a temporary directory),
// on a process-local memq:// bus (idle: no frames), as systemd would run it with WatchdogSec=.
class AgentProcess {
 public:
  AgentProcess(const testing::TempDir& dir, const std::string& notify_socket,
               const std::string& watchdog_usec)
      : log_(dir.file("agent.log")) {
    std::string yaml, error;
    EXPECT_TRUE(
        ReadWholeFile(std::string(CALIBD_SOURCE_DIR) + "/deploy/config/calibd.yaml", &yaml, &error))
        << error;
    const std::string key = "directory: /var/lib/calibd";
    const size_t at = yaml.find(key);
    EXPECT_NE(at, std::string::npos) << "the default config's store directory moved";
    if (at != std::string::npos) yaml.replace(at, key.size(), "directory: " + dir.file("store"));
    EXPECT_TRUE(WriteFileAtomic(dir.file("calibd.yaml"), yaml, &error)) << error;
    const std::string config = dir.file("calibd.yaml");
    pid_ = ::fork();
    if (pid_ == 0) {
      ::setenv("NOTIFY_SOCKET", notify_socket.c_str(), 1);
      if (!watchdog_usec.empty()) {
        ::setenv("WATCHDOG_USEC", watchdog_usec.c_str(), 1);
        ::setenv("WATCHDOG_PID", std::to_string(::getpid()).c_str(), 1);  // kept by exec
      }
      const int fd = ::open(log_.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) ::dup2(fd, STDERR_FILENO);
      ::execl(CALIBD_AGENT_EXE, CALIBD_AGENT_EXE, "--config", config.c_str(), "--lcm-url",
              "memq://", static_cast<char*>(nullptr));
      ::_exit(127);
    }
  }
  ~AgentProcess() {
    if (pid_ > 0 && !reaped_) {
      ::kill(pid_, SIGKILL);
      ::waitpid(pid_, nullptr, 0);
    }
  }
  pid_t pid() const { return pid_; }
  /// The exit code, -1 when killed by a signal or not exited within `timeout_s`.
  int Wait(double timeout_s) {
    const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
    int status = 0;
    while (Clock::now() < end) {
      if (::waitpid(pid_, &status, WNOHANG) == pid_) {
        reaped_ = true;
        return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
      }
      ::usleep(10000);
    }
    return -1;
  }
  std::string Log() const {
    std::string text, error;
    ReadWholeFile(log_, &text, &error);
    return text;
  }

 private:
  std::string log_;
  pid_t pid_ = -1;
  bool reaped_ = false;
};

// Datagrams until `wanted` arrives (included) or `timeout_ms` passes; false when it did not.
bool ReceiveUntil(NotifySocket* socket, const std::string& wanted, int timeout_ms,
                  std::vector<std::string>* received) {
  const auto end = Clock::now() + std::chrono::milliseconds(timeout_ms);
  while (Clock::now() < end) {
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(end - Clock::now()).count();
    const std::optional<std::string> msg = socket->Receive(static_cast<int>(left) + 1);
    if (!msg) continue;
    received->push_back(*msg);
    if (*msg == wanted) return true;
  }
  return false;
}

TEST(AgentSystemdTest, ReadyThenWatchdogPingsThenStoppingOnSigterm) {
  testing::TempDir dir;
  NotifySocket socket(dir.file("notify.sock"));
  ASSERT_TRUE(socket.bound());
  constexpr int64_t kWatchdogUs = 400000;
  AgentProcess agent(dir, dir.file("notify.sock"), std::to_string(kWatchdogUs));
  ASSERT_GT(agent.pid(), 0);

  // READY=1 once Init has set up the store, detectors and LCM (slow under sanitizers).
  std::vector<std::string> received;
  ASSERT_TRUE(ReceiveUntil(&socket, "READY=1", 120000, &received)) << agent.Log();

  // Then, idle: STATUS=idle once, and a ping every half interval (200 ms): about 10 in 2 s. The
  // gap between pings must stay below the interval itself, or systemd would kill the agent.
  std::vector<Clock::time_point> pings;
  int idle_status = 0;
  const auto start = Clock::now();
  const auto end = start + std::chrono::seconds(2);
  while (Clock::now() < end) {
    const std::optional<std::string> msg = socket.Receive(50);
    if (!msg) continue;
    if (*msg == "WATCHDOG=1")
      pings.push_back(Clock::now());
    else if (*msg == "STATUS=idle")
      ++idle_status;
    else
      ADD_FAILURE() << "unexpected datagram '" << *msg << "'";
  }
  EXPECT_EQ(idle_status, 1) << "STATUS= only when the state changes";
  ASSERT_GE(pings.size(), 3u) << agent.Log();
  EXPECT_LE(pings.size(), 16u) << "pings at half the interval, not every tick";
  int64_t max_gap_us =
      std::chrono::duration_cast<std::chrono::microseconds>(pings.front() - start).count();
  for (size_t i = 1; i < pings.size(); ++i)
    max_gap_us = std::max<int64_t>(
        max_gap_us,
        std::chrono::duration_cast<std::chrono::microseconds>(pings[i] - pings[i - 1]).count());
  std::printf("%zu pings in 2 s, longest gap %.0f ms (watchdog %.0f ms)\n", pings.size(),
              static_cast<double>(max_gap_us) * 1e-3, static_cast<double>(kWatchdogUs) * 1e-3);
  EXPECT_LT(max_gap_us, kWatchdogUs);

  ASSERT_EQ(::kill(agent.pid(), SIGTERM), 0);
  received.clear();
  EXPECT_TRUE(ReceiveUntil(&socket, "STOPPING=1", 10000, &received)) << agent.Log();
  EXPECT_EQ(agent.Wait(30.0), 0) << agent.Log();
}

TEST(AgentSystemdTest, NoWatchdogPingsWhenNoneIsAsked) {
  testing::TempDir dir;
  NotifySocket socket(dir.file("notify.sock"));
  ASSERT_TRUE(socket.bound());
  AgentProcess agent(dir, dir.file("notify.sock"), "");
  ASSERT_GT(agent.pid(), 0);
  std::vector<std::string> received;
  ASSERT_TRUE(ReceiveUntil(&socket, "READY=1", 120000, &received)) << agent.Log();
  received.clear();
  ReceiveUntil(&socket, "WATCHDOG=1", 1000, &received);
  EXPECT_EQ(received, std::vector<std::string>{"STATUS=idle"});
  ASSERT_EQ(::kill(agent.pid(), SIGINT), 0);
  EXPECT_TRUE(ReceiveUntil(&socket, "STOPPING=1", 10000, &received)) << agent.Log();
  EXPECT_EQ(agent.Wait(30.0), 0) << agent.Log();
}

}  // namespace
}  // namespace calibd
