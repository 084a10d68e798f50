// Storage faults through the real calibd-agent process (issue 9): the store's filesystem turns
// read-only before an `updated` result is committed. The failure must reach the user (the status
// message's last_error, the log, DTC 5A0044 in the health message and the DTC file) while the
// previous calibration stays in use and its files stay byte for byte as they were; once the
// filesystem is writable again the next commit goes through and the DTC passes.

#include <gtest/gtest.h>
#include <sys/stat.h>

#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "agent_outputs.hpp"
#include "calibd/calibration_result_t.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/health_t.hpp"
#include "run_command.hpp"
#include "temp_dir.hpp"
#include "tmpfs_mount.hpp"

namespace calibd {
namespace {

namespace fs = std::filesystem;
using testing::Published;
using testing::ReadPublished;
using testing::RunCommand;
using testing::TruthExtrinsic;

constexpr uint32_t kStoreWriteFailedDtc = 0x5A0044;
constexpr int64_t kTenDaysS = 10 * 24 * 3600;

std::string ReadText(const std::string& path) {
  std::string text, error;
  EXPECT_TRUE(ReadWholeFile(path, &text, &error)) << error;
  return text;
}

// Every regular file under `root` (relative name -> contents).
std::map<std::string, std::string> Snapshot(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file())
      files[fs::relative(e.path(), root).string()] = ReadText(e.path().string());
  return files;
}

// Only the first num_active_dtcs entries count: LCM's decode leaves a longer vector from an
// earlier message as it was when the count is 0.
bool HasActiveDtc(const health_t& h, uint32_t dtc) {
  const auto end =
      h.active_dtcs.begin() +
      std::min<ptrdiff_t>(h.num_active_dtcs, static_cast<ptrdiff_t>(h.active_dtcs.size()));
  return std::find(h.active_dtcs.begin(), end, static_cast<int32_t>(dtc)) != end;
}

TEST(AgentStoreFaultTest, ReadOnlyStoreReportsTheFailedCommitAndKeepsThePreviousCalibration) {
  testing::TempDir dir;
  const testing::TmpfsMount mount(dir.file("mnt"), "size=1m,mode=0700");
  CALIBD_REQUIRE_TMPFS(mount);
  // The default drive at 2 Hz: 40 frame pairs (as test_calibrate_cli; agent.min_frames 30 lets
  // them be solved), serials fixed so that the stored calibration belongs to these sensors.
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) +
                       " --quiet --seed 5 --lidar ot128 --rate 2 --image-encoding jpeg"
                       " --lidar-serial LDR-F9 --camera-serial CAM-F9 --out " +
                       dir.file("s.lcmlog") + " --truth " + dir.file("truth.json") +
                       " --config-out " + dir.file("agent.yaml")),
            0);
  const std::string store_dir = dir.file("mnt/store");
  const std::string uds_dir = dir.file("uds");
  fs::create_directories(uds_dir);
  {
    std::ofstream(dir.file("secret")) << "store-fault-test-secret-0123456789";
    fs::permissions(dir.file("secret"), fs::perms::owner_read | fs::perms::owner_write);
    std::string yaml = ReadText(dir.file("agent.yaml"));
    // CAN on an interface that does not exist: the agent logs it and retries, and its UDS
    // server keeps the DTCs (agent.uds.state_dir) as on the vehicle.
    yaml += "agent:\n  auto_commit: true\n  min_frames: 30\n  store:\n    directory: " + store_dir +
            "\n  can:\n    enabled: true\n    interface: calibdnone0\n  uds:\n    secret_file: " +
            dir.file("secret") + "\n    state_dir: " + uds_dir + "\n";
    std::string error;
    ASSERT_TRUE(WriteFileAtomic(dir.file("agent.yaml"), yaml, &error)) << error;
  }

  // The previous calibration: 3 deg off the truth, made ten days ago for these sensors.
  CalibrationStoreConfig store_config;
  store_config.directory = store_dir;
  StoredCalibration previous;
  previous.created_unix_s = static_cast<int64_t>(std::time(nullptr)) - kTenDaysS;
  const Pose truth = TruthExtrinsic(dir.file("truth.json"));
  previous.T_camera_lidar = truth;
  previous.T_camera_lidar.linear() =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d(1, 1, 0).normalized()) * truth.linear();
  previous.lidar_serial = "LDR-F9";
  previous.camera_serial = "CAM-F9";
  previous.source = "end_of_line";
  previous.verdict = "end_of_line";
  {
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(store_config, &error)) << error;
    ASSERT_TRUE(store.Commit(previous, &error)) << error;
  }
  const auto files_before = Snapshot(store_dir);
  auto agent = [&](const std::string& name) {
    return RunCommand(std::string(CALIBD_AGENT_EXE) + " --once --calibrate-now --config " +
                      dir.file("agent.yaml") + " --lcm-url 'file://" + dir.file("s.lcmlog") +
                      "?speed=0' --publish-url 'file://" + dir.file(name + ".lcmlog") +
                      "?mode=w' 2> " + dir.file(name + ".log"));
  };

  // Read-only store: the session ends `updated` (exit 0), its commit fails.
  ASSERT_TRUE(mount.SetReadOnly(true)) << std::strerror(errno);
  EXPECT_EQ(agent("ro"), 0) << ReadText(dir.file("ro.log"));
  const std::string log = ReadText(dir.file("ro.log"));
  EXPECT_NE(log.find("Read-only file system (the previous calibration stays in use)"),
            std::string::npos)
      << log;
  const Published ro = ReadPublished(dir.file("ro.lcmlog"));
  EXPECT_EQ(ro.last_result.verdict, +calibration_result_t::VERDICT_UPDATED);
  EXPECT_EQ(ro.last_status.last_error.rfind("commit_failed: ", 0), 0u) << ro.last_status.last_error;
  EXPECT_NE(ro.last_status.last_error.find(store_dir), std::string::npos)
      << ro.last_status.last_error;
  EXPECT_NE(ro.last_status.last_error.find("Read-only file system"), std::string::npos)
      << ro.last_status.last_error;
  EXPECT_TRUE(HasActiveDtc(ro.last_health, kStoreWriteFailedDtc));
  // Still the previous calibration: valid, ten days old.
  EXPECT_EQ(ro.last_health.calibration_state, +health_t::CALIB_VALID);
  EXPECT_GE(ro.last_health.calibration_age_s, kTenDaysS);
  EXPECT_LT(ro.last_health.calibration_age_s, kTenDaysS + 600);
  // The DTC persisted: testFailed, this cycle, pending, confirmed, since last clear (0x2F).
  EXPECT_NE(ReadText(uds_dir + "/dtc_status").find("5A0044 2F\n"), std::string::npos)
      << ReadText(uds_dir + "/dtc_status");
  EXPECT_EQ(Snapshot(store_dir), files_before) << "the store's files changed";
  {
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(store_config, &error)) << error;
    ASSERT_NE(store.current(), nullptr);
    EXPECT_EQ(store.current()->version, 1);
    EXPECT_TRUE(store.current()->T_camera_lidar.matrix() == previous.T_camera_lidar.matrix());
  }

  // Writable again: the same session's result is committed and the DTC passes.
  ASSERT_TRUE(mount.SetReadOnly(false)) << std::strerror(errno);
  EXPECT_EQ(agent("rw"), 0) << ReadText(dir.file("rw.log"));
  const Published rw = ReadPublished(dir.file("rw.lcmlog"));
  EXPECT_EQ(rw.last_result.verdict, +calibration_result_t::VERDICT_UPDATED);
  EXPECT_EQ(rw.last_status.last_error, "");
  EXPECT_FALSE(HasActiveDtc(rw.last_health, kStoreWriteFailedDtc)) << ReadText(dir.file("rw.log"));
  EXPECT_EQ(rw.last_health.calibration_state, +health_t::CALIB_VALID);
  EXPECT_LT(rw.last_health.calibration_age_s, 600);
  // Passed (testFailed cleared); confirmed and failed since the last clear stay (0x2C).
  EXPECT_NE(ReadText(uds_dir + "/dtc_status").find("5A0044 2C\n"), std::string::npos)
      << ReadText(uds_dir + "/dtc_status");
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
