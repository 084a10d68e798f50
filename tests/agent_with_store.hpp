#pragma once
// The set-up the real-agent store tests share (test_agent_store_faults, test_agent_restart): a
// simulated drive at 2 Hz (40 frame pairs) with fixed sensor serials, an agent config with
// auto-commit, min_frames 30, its store in `store_dir`, UDS state on a CAN interface that does
// not exist (the server keeps its DTCs as on the vehicle), and a stored calibration 3 deg off the
// truth, made ten days ago for these sensors. Helpers to compare the store's files and read DTCs.

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>

#include "agent_outputs.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/health_t.hpp"
#include "run_command.hpp"
#include "short_session.hpp"
#include "temp_dir.hpp"

namespace calibd::testing {

inline std::string ReadText(const std::string& path) {
  std::string text, error;
  EXPECT_TRUE(ReadWholeFile(path, &text, &error)) << error;
  return text;
}

/// Every regular file under `root` but those named `except` (relative name -> contents).
inline std::map<std::string, std::string> StoreFiles(const std::string& root,
                                                     const std::string& except = "") {
  namespace fs = std::filesystem;
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file() && (except.empty() || e.path().filename() != except))
      files[fs::relative(e.path(), root).string()] = ReadText(e.path().string());
  return files;
}

/// Only the first num_active_dtcs entries count: LCM's decode leaves a longer vector from an
/// earlier message as it was when the count is 0.
inline bool HasActiveDtc(const health_t& h, uint32_t dtc) {
  const auto end =
      h.active_dtcs.begin() +
      std::min<ptrdiff_t>(h.num_active_dtcs, static_cast<ptrdiff_t>(h.active_dtcs.size()));
  return std::find(h.active_dtcs.begin(), end, static_cast<int32_t>(dtc)) != end;
}

struct AgentWithStore {
  std::string config;  ///< the agent's config file
  std::string log;     ///< the drive, an LCM log
  std::string uds_dir;
  StoredCalibration previous;  ///< what the store holds
};

constexpr int64_t kTenDaysS = 10 * 24 * 3600;

/// Makes the drive, the config and the stored calibration in `dir`; `tag` names the serials
/// (LDR-<tag>, CAM-<tag>). Fails the test (check HasFatalFailure) when a step fails.
inline void MakeAgentWithStore(const TempDir& dir, const std::string& store_dir,
                               const std::string& tag, AgentWithStore* out) {
  namespace fs = std::filesystem;
  ASSERT_EQ(
      RunCommand(std::string(CALIBD_SIM_EXE) +
                 " --quiet --seed 5 --lidar ot128 --rate 2 --image-encoding jpeg"
                 " --lidar-serial LDR-" +
                 tag + " --camera-serial CAM-" + tag + " --out " + dir.file("s.lcmlog") +
                 " --truth " + dir.file("truth.json") + " --config-out " + dir.file("agent.yaml")),
      0);
  out->config = dir.file("agent.yaml");
  out->log = dir.file("s.lcmlog");
  out->uds_dir = dir.file("uds");
  fs::create_directories(out->uds_dir);
  std::ofstream(dir.file("secret")) << "agent-store-test-secret-" << tag << "-0123456789";
  fs::permissions(dir.file("secret"), fs::perms::owner_read | fs::perms::owner_write);
  std::string yaml = ReadText(out->config);
  yaml += "agent:\n  auto_commit: true\n  min_frames: 30\n  store:\n    directory: " + store_dir +
          "\n  can:\n    enabled: true\n    interface: calibdnone0\n  uds:\n    secret_file: " +
          dir.file("secret") + "\n    state_dir: " + out->uds_dir + "\n";
  yaml += ShortSessionEngineYaml();
  std::string error;
  ASSERT_TRUE(WriteFileAtomic(out->config, yaml, &error)) << error;

  StoredCalibration& previous = out->previous;
  previous.created_unix_s = static_cast<int64_t>(std::time(nullptr)) - kTenDaysS;
  const Pose truth = TruthExtrinsic(dir.file("truth.json"));
  previous.T_camera_lidar = truth;
  previous.T_camera_lidar.linear() =
      Eigen::AngleAxisd(3.0 * M_PI / 180.0, Eigen::Vector3d(1, 1, 0).normalized()) * truth.linear();
  previous.lidar_serial = "LDR-" + tag;
  previous.camera_serial = "CAM-" + tag;
  previous.source = "end_of_line";
  previous.verdict = "end_of_line";
  CalibrationStoreConfig store_config;
  store_config.directory = store_dir;
  CalibrationStore store;
  ASSERT_TRUE(store.Open(store_config, &error)) << error;
  ASSERT_TRUE(store.Commit(previous, &error)) << error;
}

}  // namespace calibd::testing
