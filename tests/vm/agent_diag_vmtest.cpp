// Inside the test VM: the real calibd-agent's workshop diagnostics end to end (issue 6). The agent
// runs as its own process with CAN on vcan0 (UDS on the kernel's can-isotp, the 1 Hz status frame
// on a raw socket) and GPIO on the gpio-sim chip `calibd-sim` (tests/vm/guest-init.sh); calibd-sim
// publishes a simulated drive over LCM UDP multicast on the guest's loopback, looping for the
// whole suite, as the sensor drivers would. What a workshop or a factory line sees is asserted:
//   - calibd-tester's outputs and exit codes: the workshop flow to an `updated` verdict, commit,
//     the store on disk near the simulator's truth, DIDs read back; NRCs 0x24, 0x33, 0x22;
//   - an independent client: scapy's UDS layer over its own user-space ISO-TP
//     (tests/vm/uds_scapy_client.py), bytes compared with calibd-tester's;
//   - the status frame as captured from the bus (CRC, alive counter, period, state);
//   - the start button (pulled with bounce on the simulator's side) starting a session, and the
//     status lamp's level read from the simulator's side: blinking while running, steady after.
//
// Files: tests/CMakeLists.txt puts into the shared folder (this binary's folder in the guest) the
// session (session.lcmlog, truth.json, calib.yaml), calibd-agent, calibd-sim, calibd-tester and
// the scapy client; the guest does not see a build tree under /tmp. Each test writes the agent's
// log there as agent-<test>.log. Secrets, stores and UDS state go under the guest's own /tmp
// (LoadSecret checks owner and mode, which a 9p folder reports as the host decides).

#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "calibd/core/geometry.hpp"
#include "calibd/core/status_frame.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/can_raw_socket.hpp"
#include "run_command.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

using testing::RunCommand;
using testing::TempDir;

constexpr char kInterface[] = "vcan0";
constexpr uint32_t kStatusFrameId = 0x3C0;  // agent.can.status_frame_id's default
// ttl=0: the datagrams stay on the guest; a receive buffer for whole 1.6 MB LiDAR messages.
constexpr char kLcmUrl[] = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216";
constexpr char kSoftwareVersion[] = "calibd-vmtest";  // DID F195 (agent.software_version)
constexpr char kEcuSerial[] = "ECU-VM-0001";          // DID F18C (agent.uds.ecu_serial)
constexpr unsigned kInterlock = 0, kStartButton = 1, kStatusLamp = 2;  // gpio-sim offsets
constexpr double kRad2Deg = 180.0 / M_PI;
// The replay's pace: 5 Hz frame pairs at half speed, 2.5 pairs/s, which the emulated guest's
// detectors keep up with (a session ends on coverage after about one drive, 40 s).
constexpr char kReplaySpeed[] = "0.5";

int64_t NowUs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1000000 + ts.tv_nsec / 1000;
}
void SleepMs(int ms) { ::usleep(static_cast<useconds_t>(ms) * 1000); }

std::string Env(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : "";
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

/// The shared folder: where run_gtest.sh put this binary and the build put the rest.
std::string Shared() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : self.parent_path().string();
}
std::string InShared(const std::string& name) { return Shared() + "/" + name; }

/// A child process running `command` under /bin/sh with its output into `log`.
class Child {
 public:
  ~Child() { Stop(); }
  bool Start(const std::string& command, const std::string& log) {
    pid_ = ::fork();
    if (pid_ < 0) return false;
    if (pid_ == 0) {
      const std::string line = "exec " + command + " >" + log + " 2>&1";
      ::execl("/bin/sh", "sh", "-c", line.c_str(), static_cast<char*>(nullptr));
      ::_exit(127);
    }
    return true;
  }
  bool running() {
    if (pid_ <= 0) return false;
    int status = 0;
    const pid_t r = ::waitpid(pid_, &status, WNOHANG);
    if (r == 0) return true;
    exit_code_ = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
    pid_ = -1;
    return false;
  }
  /// SIGTERM, then SIGKILL after `grace_ms`; the exit code (-1: killed by a signal, or none).
  int Stop(int grace_ms = 10000) {
    if (!running()) return exit_code_;
    ::kill(pid_, SIGTERM);
    for (int waited = 0; waited < grace_ms && running(); waited += 20) SleepMs(20);
    if (running()) {
      ::kill(pid_, SIGKILL);
      int status = 0;
      ::waitpid(pid_, &status, 0);
      pid_ = -1;
      exit_code_ = -1;
    }
    return exit_code_;
  }

 private:
  pid_t pid_ = -1;
  int exit_code_ = -1;
};

struct ToolRun {
  int code = -1;
  std::string out, err;
};

/// One decoded status frame with the kernel's receive time.
struct SeenFrame {
  int64_t t_ns = 0;
  StatusFrameCheck check;
};

/// Captures the agent's status frames from vcan0 on a thread (a raw socket filtered on its id).
class FrameMonitor {
 public:
  ~FrameMonitor() { Stop(); }
  bool Start(std::string* error) {
    CanRawConfig config;
    config.interface = kInterface;
    config.filters[0] = {kStatusFrameId, 0x7FF, false};
    config.num_filters = 1;
    config.error_frames = false;
    if (!socket_.Start(config, NowUs(), error)) return false;
    if (socket_.fd() < 0) {
      *error = "raw CAN socket on vcan0 not open: " + socket_.status().last_error;
      return false;
    }
    stop_ = false;
    thread_ = std::thread([this] { Loop(); });
    return true;
  }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    socket_.Stop();
  }
  std::vector<SeenFrame> frames() {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_;
  }
  size_t count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return frames_.size();
  }
  /// Waits up to `timeout_s` for a frame (after the `after`-th) whose status satisfies `pred`.
  template <class Pred>
  bool WaitFor(Pred pred, double timeout_s, size_t after = 0, SeenFrame* found = nullptr) {
    const int64_t end = NowUs() + static_cast<int64_t>(timeout_s * 1e6);
    for (;;) {
      {
        std::lock_guard<std::mutex> lock(mutex_);
        for (size_t i = after; i < frames_.size(); ++i) {
          if (frames_[i].check.crc_ok && pred(frames_[i].check.status)) {
            if (found != nullptr) *found = frames_[i];
            return true;
          }
        }
      }
      if (NowUs() >= end) return false;
      SleepMs(50);
    }
  }

 private:
  void Loop() {
    while (!stop_) {
      pollfd p{socket_.fd(), POLLIN, 0};
      ::poll(&p, 1, 50);
      CanFrame frame;
      while (socket_.Receive(&frame) == CanIo::kOk) {
        if (frame.id != kStatusFrameId || frame.len != kStatusFrameBytes) continue;
        StatusFrameBytes bytes{};
        std::copy(frame.data.begin(), frame.data.begin() + kStatusFrameBytes, bytes.begin());
        std::lock_guard<std::mutex> lock(mutex_);
        frames_.push_back({frame.timestamp_ns, DecodeStatusFrame(bytes)});
      }
    }
  }

  CanRawSocket socket_;
  std::thread thread_;
  std::atomic<bool> stop_{true};
  std::mutex mutex_;
  std::vector<SeenFrame> frames_;
};

const char* StateName(StatusFrame::State s) {
  static const char* names[] = {"idle", "collecting", "solving", "done", "failed", "aborted"};
  const auto i = static_cast<size_t>(s);
  return i < 6 ? names[i] : "?";
}

/// The true T_camera_lidar of calibd-sim's truth file.
Pose TruthExtrinsic(const std::string& path) {
  const auto j = nlohmann::json::parse(ReadFile(path));
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = j["T_camera_lidar"][r][c].get<double>();
  return T;
}

#define EXPECT_HAS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

class AgentDiagVm : public ::testing::Test {
 protected:
  /// Once per suite: multicast on the guest's loopback (LCM's udpm, as tools/sim's private
  /// network does on a host), a receive buffer that holds whole sweeps, and the simulator
  /// publishing the drive in a loop for the whole suite.
  static void SetUpTestSuite() {
    if (Env("CALIBD_VM") != "1") return;  // SetUp reports it
    RunCommand(
        "ip link set lo multicast on; ip route replace 224.0.0.0/4 dev lo; "
        "sysctl -q -w net.core.rmem_max=33554432 net.core.rmem_default=4194304");
    sim_ = new Child;
    sim_->Start(InShared("calibd-sim") + " --replay " + InShared("session.lcmlog") +
                    " --publish-url '" + kLcmUrl + "' --loops 40 --speed " + kReplaySpeed +
                    " --start-delay 0",
                InShared("sim.log"));
  }
  static void TearDownTestSuite() {
    delete sim_;  // stops it
    sim_ = nullptr;
  }

  void SetUp() override {
    ASSERT_EQ(Env("CALIBD_VM"), "1") << "not inside the test VM: run with ctest -R agent_diag";
    sim_dir_ = Env("CALIBD_VM_GPIOSIM");
    ASSERT_FALSE(sim_dir_.empty()) << "no gpio-sim chip in the VM";
    ASSERT_NE(sim_, nullptr);
    ASSERT_TRUE(sim_->running()) << "calibd-sim stopped publishing:\n"
                                 << ReadFile(InShared("sim.log"));
    // The factory line at rest: interlock asserted (active high), start button released.
    Pull(kInterlock, true);
    Pull(kStartButton, false);
    std::string error;
    ASSERT_TRUE(monitor_.Start(&error)) << error;
  }
  void TearDown() override {
    monitor_.Stop();
    if (agent_started_) {
      const int code = agent_.Stop();
      EXPECT_EQ(code, 0) << "calibd-agent did not stop cleanly on SIGTERM; its log:\n"
                         << ReadFile(agent_log_);
    }
  }

  /// Writes the agent's config (calib.yaml + an agent section: CAN on vcan0, UDS, GPIO, the
  /// store) and starts it; returns once it answers on the bus.
  void StartAgent() {
    const std::string d = dir_.path().string();
    std::filesystem::create_directories(d + "/uds");
    {
      std::ofstream(secret()) << "vmtest-secret-of-this-vehicle-0123456789";
      std::filesystem::permissions(
          secret(), std::filesystem::perms::owner_read | std::filesystem::perms::owner_write);
    }
    std::string yaml = ReadFile(InShared("calib.yaml"));
    ASSERT_FALSE(yaml.empty()) << "no calib.yaml in the shared folder (the build writes it)";
    yaml += std::string("agent:\n") + "  lcm_url: \"" + kLcmUrl + "\"\n" +
            "  software_version: " + kSoftwareVersion + "\n" +
            "  store:\n    directory: " + store_dir() + "\n" +
            // 60 pairs (the coverage gates alone end at about 30, whose small images leave
            // 1-2 cm of translation error): 25 s of the replay, solved in about 10 s.
            "  min_frames: 60\n  max_duration_s: 150\n" +
            "  can:\n    enabled: true\n    interface: " + kInterface + "\n" +
            "  uds:\n    secret_file: " + secret() + "\n    state_dir: " + d + "/uds\n" +
            "    ecu_serial: " + kEcuSerial + "\n" + "  gpio:\n" + GpioLine("interlock") +
            GpioLine("start_button") + GpioLine("status_lamp") +
            "    start_button_debounce_ms: 30\n";
    std::string error;
    ASSERT_TRUE(WriteFileAtomic(dir_.file("agent.yaml"), yaml, &error)) << error;
    agent_log_ = InShared(
        "agent-" + std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
        ".log");
    ASSERT_TRUE(agent_.Start(InShared("calibd-agent") + " --config " + dir_.file("agent.yaml"),
                             agent_log_));
    agent_started_ = true;
    // Ready: its log says so, then UDS answers (F195 over the bus).
    const int64_t end = NowUs() + 90 * 1000000LL;
    bool ready = false;
    while (NowUs() < end && !ready) {
      ASSERT_TRUE(agent_.running()) << "calibd-agent exited; its log:\n" << ReadFile(agent_log_);
      ready = ReadFile(agent_log_).find("ready on") != std::string::npos;
      if (!ready) SleepMs(200);
    }
    ASSERT_TRUE(ready) << "calibd-agent not ready after 90 s; its log:\n" << ReadFile(agent_log_);
    ToolRun r;
    for (int attempt = 0; attempt < 20; ++attempt) {
      r = Tester("read F195");
      if (r.code == 0) break;
      SleepMs(500);
    }
    ASSERT_EQ(r.code, 0) << "no UDS answer from the agent: " << r.err << "\nits log:\n"
                         << ReadFile(agent_log_);
    ASSERT_EQ(r.out, "F195 software version: " + std::string(kSoftwareVersion) + "\n");
  }

  static std::string GpioLine(const char* name) {
    return std::string("    ") + name +
           ":\n      enabled: true\n      chip: calibd-sim\n      line: " + name + "\n";
  }

  /// calibd-tester on vcan0 (P2 2 s: the guest is emulated and its agent busy detecting).
  ToolRun Tester(const std::string& args) {
    ToolRun run;
    const std::string out = dir_.file("tester-out.txt"), err = dir_.file("tester-err.txt");
    run.code = RunCommand(InShared("calibd-tester") + " --interface " + kInterface +
                          " --p2-ms 2000 " + args + " >" + out + " 2>" + err);
    run.out = ReadFile(out);
    run.err = ReadFile(err);
    return run;
  }

  /// The simulator pulls line `offset` up or down (a switch on the line).
  void Pull(unsigned offset, bool up) {
    const std::string path = sim_dir_ + "/sim_gpio" + std::to_string(offset) + "/pull";
    std::ofstream out(path);
    out << (up ? "pull-up" : "pull-down");
    out.close();
    ASSERT_TRUE(out) << "cannot write " << path;
  }
  /// The level the simulator sees on line `offset` (for the lamp: what the agent drives).
  int SimValue(unsigned offset) {
    std::ifstream in(sim_dir_ + "/sim_gpio" + std::to_string(offset) + "/value");
    int value = -1;
    in >> value;
    return value;
  }
  /// Samples the lamp every 20 ms for `duration_ms`.
  struct LampTrace {
    int samples = 0, on = 0, edges = 0;
    int64_t longest_on_us = 0, longest_off_us = 0;
  };
  LampTrace SampleLamp(int duration_ms) {
    LampTrace t;
    const int64_t start = NowUs(), end = start + int64_t{duration_ms} * 1000;
    int last = -1;
    int64_t since = start;
    while (NowUs() < end) {
      const int v = SimValue(kStatusLamp);
      const int64_t now = NowUs();
      ++t.samples;
      t.on += v == 1;
      if (last >= 0 && v != last) {
        ++t.edges;
        since = now;
      }
      (v == 1 ? t.longest_on_us : t.longest_off_us) =
          std::max(v == 1 ? t.longest_on_us : t.longest_off_us, now - since);
      last = v;
      SleepMs(20);
    }
    return t;
  }

  std::string secret() const { return dir_.file("secret"); }
  std::string store_dir() const { return dir_.file("store"); }

  static Child* sim_;
  TempDir dir_;
  std::string sim_dir_;
  Child agent_;
  bool agent_started_ = false;
  std::string agent_log_;
  FrameMonitor monitor_;
};
Child* AgentDiagVm::sim_ = nullptr;

// d. The status frame from the bus: every CRC right, the alive counter advancing by one (0..14),
// 1 s apart by the kernel's receive times, an idle agent with no calibration yet.
TEST_F(AgentDiagVm, StatusFrameIsCyclicWithCrcAndAliveCounter) {
  StartAgent();
  const size_t before = monitor_.count();
  const int64_t end = NowUs() + 12 * 1000000LL;
  while (monitor_.count() < before + 6 && NowUs() < end) SleepMs(100);
  const std::vector<SeenFrame> all = monitor_.frames();
  ASSERT_GE(all.size(), before + 6) << "fewer than 6 status frames (id 0x3C0) in 12 s";
  const std::vector<SeenFrame> f(all.begin() + static_cast<long>(before), all.end());
  double sum_s = 0;
  for (size_t i = 0; i < f.size(); ++i) {
    SCOPED_TRACE("frame " + std::to_string(i));
    EXPECT_TRUE(f[i].check.crc_ok);
    EXPECT_LE(f[i].check.counter, 14);
    EXPECT_EQ(f[i].check.status.state, StatusFrame::State::kIdle);
    EXPECT_EQ(f[i].check.status.progress_percent, -1);
    EXPECT_EQ(f[i].check.status.last_verdict, StatusFrame::Verdict::kNone);
    EXPECT_EQ(f[i].check.status.calibration, StatusFrame::Calibration::kNotPerformed);
    if (i == 0) continue;
    EXPECT_EQ(f[i].check.counter, (f[i - 1].check.counter + 1) % 15);
    const double period_s = static_cast<double>(f[i].t_ns - f[i - 1].t_ns) * 1e-9;
    EXPECT_NEAR(period_s, 1.0, 0.25);
    sum_s += period_s;
  }
  const double mean_s = sum_s / static_cast<double>(f.size() - 1);
  std::printf("status frames: %zu, mean period %.3f s\n", f.size(), mean_s);
  EXPECT_NEAR(mean_s, 1.0, 0.05);
}

// b. Negative responses over the bus, from a fresh agent: results before any start 0x24; start
// without security 0x33 (the exact bytes too); interlock released 0x22; and the same start with
// the interlock asserted again is accepted (so the 0x22 was the interlock, not silent sensors).
TEST_F(AgentDiagVm, NegativeResponsesForSequenceSecurityAndInterlock) {
  StartAgent();
  ToolRun r = Tester("results");
  EXPECT_EQ(r.code, 5) << r.out << r.err;
  EXPECT_HAS(r.err, "0x31 RoutineControl refused: 0x24 requestSequenceError");

  r = Tester("calibrate --no-wait");
  EXPECT_EQ(r.code, 5) << r.out << r.err;
  EXPECT_HAS(r.err, "0x31 RoutineControl refused: 0x33 securityAccessDenied");
  // The bytes themselves: extended session, then startRoutine F0A0 (moving, no time limit).
  ToolRun raw;
  raw.code = RunCommand(InShared("calibd-tester") +
                        " --interface vcan0 --p2-ms 2000 session "
                        "extended >/dev/null && " +
                        InShared("calibd-tester") +
                        " --interface vcan0 --p2-ms 2000 raw 31 01 F0 A0 00 00 00 >" +
                        dir_.file("raw.txt") + " 2>&1");
  raw.out = ReadFile(dir_.file("raw.txt"));
  EXPECT_EQ(raw.code, 5) << raw.out;
  EXPECT_HAS(raw.out, "7F 31 33\n");

  Pull(kInterlock, false);
  SleepMs(300);
  r = Tester("--secret " + secret() + " calibrate --no-wait");
  EXPECT_EQ(r.code, 5) << r.out << r.err;
  EXPECT_HAS(r.err, "0x31 RoutineControl refused: 0x22 conditionsNotCorrect");
  const std::vector<SeenFrame> frames = monitor_.frames();
  ASSERT_FALSE(frames.empty());
  EXPECT_EQ(frames.back().check.status.state, StatusFrame::State::kIdle);

  Pull(kInterlock, true);
  SleepMs(300);
  r = Tester("--secret " + secret() + " calibrate --no-wait");
  EXPECT_EQ(r.code, 0) << r.out << r.err << "\nagent log:\n" << ReadFile(agent_log_);
  r = Tester("results");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out, "status: active\n");
  r = Tester("--secret " + secret() + " stop");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "stopped\n");
}

// 3. An independent client: scapy's UDS layer over its own ISO-TP (and over the kernel's), the
// current extrinsic's bytes equal to what calibd-tester reads.
TEST_F(AgentDiagVm, ScapyUdsClientAgrees) {
  StartAgent();
  ToolRun raw = Tester("raw 22 FD 00");
  ASSERT_EQ(raw.code, 0) << raw.err;
  ASSERT_EQ(raw.out.rfind("62 FD 00 ", 0), 0u) << raw.out;
  const std::string fd00 = raw.out.substr(9, raw.out.size() - 10);  // without the newline
  for (const char* transport : {"", " --native"}) {
    SCOPED_TRACE(*transport ? "kernel can-isotp" : "scapy ISOTPSoftSocket");
    const std::string out = dir_.file("scapy.txt");
    const int code =
        RunCommand("/usr/bin/python3 " + InShared("uds_scapy_client.py") +
                   " --interface vcan0 --expect-version " + kSoftwareVersion + " --expect-serial " +
                   kEcuSerial + transport + " >" + out + " 2>&1");
    const std::string text = ReadFile(out);
    std::printf("%s", text.c_str());
    EXPECT_EQ(code, 0) << text;
    EXPECT_HAS(text, "all checks passed\n");
    EXPECT_HAS(text, "FD00 " + fd00 + "\n");
  }
}

// 0x11 01 hardReset: the agent answers, then restarts itself in place (the same process, exec'd
// afresh: its log shows it ready a second time) and UDS answers again.
TEST_F(AgentDiagVm, HardResetRestartsTheAgentInPlace) {
  StartAgent();
  const std::string tester = InShared("calibd-tester") + " --interface vcan0 --p2-ms 2000 ";
  const int code = RunCommand(tester + "session extended >/dev/null && " + tester + "raw 11 01 >" +
                              dir_.file("reset.txt") + " 2>&1");
  EXPECT_EQ(code, 0) << ReadFile(dir_.file("reset.txt"));
  EXPECT_EQ(ReadFile(dir_.file("reset.txt")), "51 01\n");
  auto count = [&](const std::string& what) {
    const std::string log = ReadFile(agent_log_);
    int n = 0;
    for (size_t at = log.find(what); at != std::string::npos; at = log.find(what, at + 1)) ++n;
    return n;
  };
  const int64_t end = NowUs() + 90 * 1000000LL;
  while (count("ready on") < 2 && NowUs() < end && agent_.running()) SleepMs(200);
  ASSERT_TRUE(agent_.running()) << "the agent exited instead of restarting:\n"
                                << ReadFile(agent_log_);
  EXPECT_EQ(count("restarting (ECU reset)"), 1) << ReadFile(agent_log_);
  ASSERT_EQ(count("ready on"), 2) << "not ready again after the reset:\n" << ReadFile(agent_log_);
  ToolRun r;
  for (int attempt = 0; attempt < 20; ++attempt) {
    r = Tester("read F195");
    if (r.code == 0) break;
    SleepMs(500);
  }
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "F195 software version: " + std::string(kSoftwareVersion) + "\n");
}

// a. The workshop flow with calibd-tester: extended session, unlock, calibrate start, results
// polled to success with an `updated` verdict (the config's prior is 3 deg / 8 cm off), commit;
// then the store's current.json holds the truth within tolerance and DID FD00 reads it back.
// The status frame follows: collecting while it runs, done + updated after, valid once stored.
TEST_F(AgentDiagVm, WorkshopFlowCalibratesCommitsAndStores) {
  StartAgent();
  ToolRun r = Tester("session extended");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "session extended (P2 50 ms, P2* 5000 ms)\n");
  r = Tester("--secret " + secret() + " unlock");
  ASSERT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "unlocked\n");

  const size_t before = monitor_.count();
  const int64_t t0 = NowUs();
  r = Tester("--secret " + secret() + " calibrate --max-duration 150");
  std::printf("calibrate took %.1f s:\n%s", static_cast<double>(NowUs() - t0) * 1e-6,
              r.out.c_str());
  ASSERT_EQ(r.code, 0) << r.out << r.err << "\nagent log:\n" << ReadFile(agent_log_);
  EXPECT_HAS(r.out, "status: success\n");
  EXPECT_HAS(r.out, "verdict: updated\n");
  EXPECT_HAS(r.out, "reason: none\n");
  double rotation_delta_deg = 0;
  const size_t at = r.out.find("rotation delta: ");
  ASSERT_NE(at, std::string::npos) << r.out;
  std::sscanf(r.out.c_str() + at, "rotation delta: %lf", &rotation_delta_deg);
  EXPECT_NEAR(rotation_delta_deg, 3.0, 0.5) << "the prior is 3 deg off the truth";
  EXPECT_TRUE(monitor_.WaitFor(
      [](const StatusFrame& s) { return s.state == StatusFrame::State::kCollecting; }, 0, before))
      << "no status frame showed the session collecting";
  SeenFrame done;
  EXPECT_TRUE(monitor_.WaitFor(
      [](const StatusFrame& s) { return s.state == StatusFrame::State::kDone; }, 5, before, &done));
  EXPECT_EQ(done.check.status.last_verdict, StatusFrame::Verdict::kUpdated);
  EXPECT_NEAR(done.check.status.rotation_delta_deg, rotation_delta_deg, 0.002);

  r = Tester("--secret " + secret() + " commit");
  ASSERT_EQ(r.code, 0) << r.out << r.err;
  EXPECT_EQ(r.out, "commit: success\n");

  // The store on disk (as the agent's next start would read it) holds the new calibration.
  CalibrationStoreConfig store_config;
  store_config.directory = store_dir();
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(store_config, &error)) << error;
  ASSERT_NE(store.current(), nullptr) << "no current.json after the commit";
  const StoredCalibration stored = *store.current();
  EXPECT_EQ(stored.verdict, "updated");
  const Pose truth = TruthExtrinsic(InShared("truth.json"));
  const double rot_err = RotationAngle(stored.T_camera_lidar.linear(), truth.linear()) * kRad2Deg;
  const double trans_err = (stored.T_camera_lidar.translation() - truth.translation()).norm();
  std::printf("stored calibration vs truth: %.4f deg, %.4f m (%d frames, %d boards)\n", rot_err,
              trans_err, stored.frames_used, stored.boards_used);
  // The same log replayed on the host from its start, 60 pairs: 0.041 deg, 8.4 mm; here the
  // session starts anywhere in the drive. Far inside the prior's 3 deg / 80 mm.
  EXPECT_LT(rot_err, 0.15);
  EXPECT_LT(trans_err, 0.03);

  // DID FD00 reads the stored extrinsic back: 0.01 mm and micro-degree steps,
  // R = Rz(yaw) * Ry(pitch) * Rx(roll) (agent/include/calibd/agent/uds/did_codec.hpp).
  r = Tester("read FD00");
  ASSERT_EQ(r.code, 0) << r.err;
  double x = 0, y = 0, z = 0, roll = 0, pitch = 0, yaw = 0;
  ASSERT_EQ(std::sscanf(r.out.c_str(),
                        "FD00 current T_camera_lidar: x %lf mm, y %lf mm, z %lf mm, roll %lf deg, "
                        "pitch %lf deg, yaw %lf deg",
                        &x, &y, &z, &roll, &pitch, &yaw),
            6)
      << r.out;
  const Eigen::Matrix3d R_did = (Eigen::AngleAxisd(yaw / kRad2Deg, Eigen::Vector3d::UnitZ()) *
                                 Eigen::AngleAxisd(pitch / kRad2Deg, Eigen::Vector3d::UnitY()) *
                                 Eigen::AngleAxisd(roll / kRad2Deg, Eigen::Vector3d::UnitX()))
                                    .toRotationMatrix();
  EXPECT_LT(RotationAngle(R_did, stored.T_camera_lidar.linear()) * kRad2Deg, 1e-5);
  EXPECT_LT((Eigen::Vector3d(x, y, z) * 1e-3 - stored.T_camera_lidar.translation()).norm(), 2e-5);

  // The status frame: a valid calibration, 0 h old.
  const size_t after_commit = monitor_.count();
  SeenFrame valid;
  EXPECT_TRUE(monitor_.WaitFor(
      [](const StatusFrame& s) { return s.calibration == StatusFrame::Calibration::kValid; }, 3,
      after_commit, &valid));
  EXPECT_NEAR(valid.check.status.calibration_age_h, 0.0, 1.0);
}

// c. The factory line: with the interlock asserted, a start-button press (with contact bounce)
// starts a session; the lamp is off while idle, blinks at 1 Hz while collecting, and is on
// steadily once the session succeeded.
TEST_F(AgentDiagVm, StartButtonStartsASessionAndTheLampFollows) {
  StartAgent();
  const LampTrace idle = SampleLamp(1500);
  EXPECT_EQ(idle.on, 0) << "lamp not off while idle (" << idle.on << " of " << idle.samples
                        << " samples on)";

  // Press: 3 bounces of about 2 ms, held 300 ms, released (with a bounce).
  const size_t before = monitor_.count();
  for (int i = 0; i < 3; ++i) {
    Pull(kStartButton, true);
    SleepMs(2);
    Pull(kStartButton, false);
    SleepMs(2);
  }
  Pull(kStartButton, true);
  SleepMs(300);
  Pull(kStartButton, false);
  SleepMs(2);
  Pull(kStartButton, true);
  SleepMs(2);
  Pull(kStartButton, false);
  ASSERT_TRUE(monitor_.WaitFor(
      [](const StatusFrame& s) { return s.state == StatusFrame::State::kCollecting; }, 5, before))
      << "the start button did not start a session; agent log:\n"
      << ReadFile(agent_log_);

  // 1 Hz blink: about 2 edges a second, on about half the time, never on or off for 1 s.
  const LampTrace running = SampleLamp(4000);
  const std::vector<SeenFrame> seen = monitor_.frames();
  ASSERT_FALSE(seen.empty());
  const StatusFrame::State state_after = seen.back().check.status.state;
  std::printf("lamp while running: %d of %d samples on, %d edges, longest on %.2f s, off %.2f s\n",
              running.on, running.samples, running.edges,
              static_cast<double>(running.longest_on_us) * 1e-6,
              static_cast<double>(running.longest_off_us) * 1e-6);
  ASSERT_EQ(state_after, StatusFrame::State::kCollecting)
      << "the session ended within 4 s: the blink was not sampled while running";
  EXPECT_GE(running.edges, 5);
  EXPECT_LE(running.edges, 11);
  EXPECT_NEAR(static_cast<double>(running.on) / running.samples, 0.5, 0.2);
  EXPECT_LT(running.longest_on_us, 800000);
  EXPECT_LT(running.longest_off_us, 800000);

  SeenFrame done;
  ASSERT_TRUE(monitor_.WaitFor(
      [](const StatusFrame& s) {
        return s.state != StatusFrame::State::kCollecting &&
               s.state != StatusFrame::State::kSolving && s.state != StatusFrame::State::kIdle;
      },
      200, before, &done))
      << "the session did not end within 200 s; agent log:\n"
      << ReadFile(agent_log_);
  ASSERT_EQ(done.check.status.state, StatusFrame::State::kDone)
      << StateName(done.check.status.state) << "; agent log:\n"
      << ReadFile(agent_log_);
  EXPECT_EQ(done.check.status.last_verdict, StatusFrame::Verdict::kUpdated);
  const LampTrace success = SampleLamp(2500);
  EXPECT_EQ(success.on, success.samples)
      << "lamp not steady on after success: " << success.edges << " edges";
}

}  // namespace
}  // namespace calibd
