// A SIGKILL during a session through the real calibd-agent process: systemd restarts
// the agent, which must come back idle with its stored calibration, say in its log and in DTC
// 5A0300 (CALIBD_HEALTH and the DTC file) that the previous run stopped mid-session, and leave
// no session marker behind. The killed session never touched the store (files byte for byte);
// a clean stop (SIGTERM) during a session reports nothing at the next start; the next session
// that ends with a result passes the DTC.

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include "agent_outputs.hpp"
#include "agent_with_store.hpp"
#include "calibd/calibration_result_t.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/health_t.hpp"
#include "run_command.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

namespace fs = std::filesystem;
using testing::AgentWithStore;
using testing::HasActiveDtc;
using testing::kTenDaysS;
using testing::MakeAgentWithStore;
using testing::Published;
using testing::ReadPublished;
using testing::ReadText;
using testing::RunCommand;
using testing::StoreFiles;
using testing::TruthExtrinsic;
using Clock = std::chrono::steady_clock;

constexpr uint32_t kSessionInterruptedDtc = 0x5A0300;
constexpr char kMarkerName[] = "session_in_progress";

std::string ReadIfAny(const std::string& path) {
  std::string text, error;
  return ReadWholeFile(path, &text, &error) ? text : std::string();
}

// calibd-agent in the background, its stderr into `log`, as systemd runs it.
class Agent {
 public:
  Agent(const std::vector<std::string>& args, const std::string& log) {
    pid_ = ::fork();
    if (pid_ == 0) {
      const int fd = ::open(log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) ::dup2(fd, STDERR_FILENO);
      std::vector<char*> argv;
      argv.push_back(const_cast<char*>(CALIBD_AGENT_EXE));
      for (const std::string& a : args) argv.push_back(const_cast<char*>(a.c_str()));
      argv.push_back(nullptr);
      ::execv(CALIBD_AGENT_EXE, argv.data());
      ::_exit(127);
    }
  }
  ~Agent() {
    if (pid_ > 0 && !reaped_) Signal(SIGKILL);
  }
  /// Sends `signal` and waits for the exit: the exit code, or -signal when killed by one.
  int Signal(int signal) {
    ::kill(pid_, signal);
    int status = 0;
    ::waitpid(pid_, &status, 0);
    reaped_ = true;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -WTERMSIG(status);
  }

 private:
  pid_t pid_ = -1;
  bool reaped_ = false;
};

// Waits up to `timeout_s` for `text` in the file at `path`.
bool WaitForText(const std::string& path, const std::string& text, double timeout_s) {
  const auto end = Clock::now() + std::chrono::duration<double>(timeout_s);
  while (Clock::now() < end) {
    if (ReadIfAny(path).find(text) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

TEST(AgentRestartTest, KilledDuringASessionRestartsIdleWithTheStoredCalibrationAndADtc) {
  testing::TempDir dir;
  // The default drive at 2 Hz (40 frame pairs, 20 s in real time), serials fixed so that the
  // stored calibration belongs to these sensors (as test_agent_store_faults).
  const std::string store_dir = dir.file("store");
  const std::string marker = store_dir + "/" + kMarkerName;
  // The default drive at 2 Hz (40 frame pairs, 20 s in real time).
  AgentWithStore setup;
  MakeAgentWithStore(dir, store_dir, "R9", &setup);
  if (HasFatalFailure()) return;
  const std::string& uds_dir = setup.uds_dir;
  const Pose truth = TruthExtrinsic(dir.file("truth.json"));
  CalibrationStoreConfig store_config;
  store_config.directory = store_dir;
  const auto files_before = StoreFiles(store_dir, kMarkerName);
  const std::string config = dir.file("agent.yaml");
  // The drive in real time: a session collects for 20 s, long enough to be stopped mid-way.
  const std::string live = "file://" + dir.file("s.lcmlog") + "?speed=1";
  auto out = [&](const std::string& name) {
    return "file://" + dir.file(name + ".lcmlog") + "?mode=w";
  };

  // 1. Killed while collecting: the marker names the session; the store is as it was.
  {
    Agent agent(
        {"--calibrate-now", "--config", config, "--lcm-url", live, "--publish-url", out("killed")},
        dir.file("killed.log"));
    ASSERT_TRUE(WaitForText(dir.file("killed.log"), "session 1 started by '--calibrate-now'", 60))
        << ReadIfAny(dir.file("killed.log"));
    std::this_thread::sleep_for(std::chrono::seconds(1));  // frames arriving
    EXPECT_EQ(agent.Signal(SIGKILL), -SIGKILL);
  }
  const std::string killed_log = ReadText(dir.file("killed.log"));
  EXPECT_EQ(killed_log.find("collection ended"), std::string::npos) << killed_log;
  ASSERT_TRUE(fs::exists(marker)) << killed_log;
  EXPECT_NE(ReadText(marker).find("session 1\ntrigger --calibrate-now\n"), std::string::npos)
      << ReadText(marker);
  EXPECT_EQ(StoreFiles(store_dir, kMarkerName), files_before) << "the store's files changed";

  // 2. Restarted (idle, as systemd restarts it): the log line, the DTC, the stored calibration.
  {
    Agent agent({"--config", config, "--lcm-url", "memq://", "--publish-url", out("restarted")},
                dir.file("restarted.log"));
    ASSERT_TRUE(WaitForText(dir.file("restarted.log"), "ready on", 60))
        << ReadIfAny(dir.file("restarted.log"));
    std::this_thread::sleep_for(std::chrono::milliseconds(2500));  // health at 1 Hz
    EXPECT_EQ(agent.Signal(SIGTERM), 0);
  }
  const std::string restarted_log = ReadText(dir.file("restarted.log"));
  EXPECT_NE(restarted_log.find("the previous run stopped during session 1 (started by "
                               "'--calibrate-now' at "),
            std::string::npos)
      << restarted_log;
  EXPECT_NE(
      restarted_log.find("Z) without a result: aborted; the stored calibration is unchanged\n"),
      std::string::npos)
      << restarted_log;
  EXPECT_NE(restarted_log.find("stored calibration version 1 (end_of_line)"), std::string::npos)
      << restarted_log;
  const Published restarted = ReadPublished(dir.file("restarted.lcmlog"));
  ASSERT_GT(restarted.health, 0);
  EXPECT_TRUE(HasActiveDtc(restarted.last_health, kSessionInterruptedDtc));
  EXPECT_EQ(restarted.last_health.calibration_state, +health_t::CALIB_VALID);
  EXPECT_GE(restarted.last_health.calibration_age_s, kTenDaysS);
  EXPECT_LT(restarted.last_health.calibration_age_s, kTenDaysS + 600);
  EXPECT_EQ(restarted.last_status.state, +calibration_status_t::STATE_IDLE);
  EXPECT_EQ(restarted.last_status.last_error.rfind("session_interrupted: the previous run", 0), 0u)
      << restarted.last_status.last_error;
  // testFailed, this cycle, pending, confirmed, failed since the last clear (0x2F).
  EXPECT_NE(ReadText(uds_dir + "/dtc_status").find("5A0300 2F\n"), std::string::npos)
      << ReadText(uds_dir + "/dtc_status");
  EXPECT_FALSE(fs::exists(marker));
  EXPECT_EQ(StoreFiles(store_dir, kMarkerName), files_before) << "the store's files changed";

  // 3. A clean stop (SIGTERM) during a session leaves no marker: nothing to report next time.
  {
    Agent agent(
        {"--calibrate-now", "--config", config, "--lcm-url", live, "--publish-url", out("stopped")},
        dir.file("stopped.log"));
    ASSERT_TRUE(WaitForText(dir.file("stopped.log"), "session 1 started by '--calibrate-now'", 60))
        << ReadIfAny(dir.file("stopped.log"));
    EXPECT_TRUE(fs::exists(marker));
    EXPECT_EQ(agent.Signal(SIGTERM), 0);
  }
  EXPECT_FALSE(fs::exists(marker)) << ReadText(dir.file("stopped.log"));
  EXPECT_EQ(StoreFiles(store_dir, kMarkerName), files_before) << "the store's files changed";

  // 4. The next session ends with a result (committed): the DTC passes, no marker is left.
  EXPECT_EQ(RunCommand(std::string(CALIBD_AGENT_EXE) + " --once --calibrate-now --config " +
                       config + " --lcm-url 'file://" + dir.file("s.lcmlog") +
                       "?speed=0' --publish-url '" + out("next") + "' 2> " + dir.file("next.log")),
            0)
      << ReadText(dir.file("next.log"));
  const std::string next_log = ReadText(dir.file("next.log"));
  EXPECT_EQ(next_log.find("the previous run stopped"), std::string::npos) << next_log;
  const Published next = ReadPublished(dir.file("next.lcmlog"));
  EXPECT_EQ(next.last_result.verdict, +calibration_result_t::VERDICT_UPDATED);
  EXPECT_FALSE(HasActiveDtc(next.last_health, kSessionInterruptedDtc)) << next_log;
  EXPECT_EQ(next.last_health.calibration_state, +health_t::CALIB_VALID);
  EXPECT_LT(next.last_health.calibration_age_s, 600);
  // Passed (testFailed cleared); confirmed and failed since the last clear stay (0x2C).
  EXPECT_NE(ReadText(uds_dir + "/dtc_status").find("5A0300 2C\n"), std::string::npos)
      << ReadText(uds_dir + "/dtc_status");
  EXPECT_FALSE(fs::exists(marker));
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(store_config, &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
  EXPECT_LT(RotationAngle(store.current()->T_camera_lidar.linear(), truth.linear()) * 180.0 / M_PI,
            0.3);
}

}  // namespace
}  // namespace calibd
