// Storage faults through the real calibd-agent process: the store's filesystem turns
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
#include "agent_with_store.hpp"
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

constexpr uint32_t kStoreWriteFailedDtc = 0x5A0044;

TEST(AgentStoreFaultTest, ReadOnlyStoreReportsTheFailedCommitAndKeepsThePreviousCalibration) {
  testing::TempDir dir;
  const testing::TmpfsMount mount(dir.file("mnt"), "size=1m,mode=0700");
  CALIBD_REQUIRE_TMPFS(mount);
  // The default drive at 2 Hz: 40 frame pairs (as test_calibrate_cli; agent.min_frames 30 lets
  // them be solved), serials fixed so that the stored calibration belongs to these sensors.
  const std::string store_dir = dir.file("mnt/store");
  AgentWithStore setup;
  MakeAgentWithStore(dir, store_dir, "F9", &setup);
  if (HasFatalFailure()) return;
  const std::string& uds_dir = setup.uds_dir;
  const StoredCalibration& previous = setup.previous;
  const Pose truth = TruthExtrinsic(dir.file("truth.json"));
  CalibrationStoreConfig store_config;
  store_config.directory = store_dir;
  const auto files_before = StoreFiles(store_dir);
  auto agent = [&](const std::string& name) {
    return RunCommand(std::string(CALIBD_AGENT_EXE) + " --once --calibrate-now --config " +
                      dir.file("agent.yaml") + " --lcm-url 'file://" + dir.file("s.lcmlog") +
                      "?speed=0' --publish-url 'file://" + dir.file(name + ".lcmlog") +
                      "?mode=w' 2> " + dir.file(name + ".log"));
  };

  // Read-only store: the session ends `updated`, its commit fails: --once exits 5.
  ASSERT_TRUE(mount.SetReadOnly(true)) << std::strerror(errno);
  EXPECT_EQ(agent("ro"), 5) << ReadText(dir.file("ro.log"));
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
  EXPECT_EQ(StoreFiles(store_dir), files_before) << "the store's files changed";
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
