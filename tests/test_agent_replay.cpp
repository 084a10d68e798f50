// Replay tests: simulated logs through the real calibd-agent process over LCM's file
// provider, for each LiDAR model: the verdict, the stored calibration against the truth, and the
// status, result and health messages the agent published (recorded with a file:// writer).

#include <gtest/gtest.h>

#include <cstdio>
#include <cstdlib>
#include <nlohmann/json.hpp>
#include <string>

#include "agent_outputs.hpp"
#include "calibd/calibration_result_t.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "run_command.hpp"
#include "short_session.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

using testing::Published;
using testing::ReadPublished;
using testing::RunCommand;
using testing::TruthExtrinsic;

class AgentReplayTest : public ::testing::TestWithParam<const char*> {};

TEST_P(AgentReplayTest, CalibratesCommitsAndThenVerifies) {
  const std::string lidar = GetParam();
  testing::TempDir dir;
  // The default drive (6-30 m and back in 20 s) at 4 Hz with JPEG images: 80 frame pairs; the
  // prior is 3 deg / 3 cm off.
  ASSERT_EQ(
      RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --seed 7 --lidar " + lidar +
                 " --rate 4 --image-encoding jpeg --prior-rot-deg 3 --prior-trans-m 0.03 --out " +
                 dir.file("s.lcmlog") + " --truth " + dir.file("truth.json") + " --config-out " +
                 dir.file("agent.yaml")),
      0);
  {
    std::string yaml, error;
    ASSERT_TRUE(ReadWholeFile(dir.file("agent.yaml"), &yaml, &error)) << error;
    yaml += "agent:\n  auto_commit: true\n  store:\n    directory: " + dir.file("store") + "\n";
    yaml += testing::ShortSessionEngineYaml();  // 80 pairs of boards ahead at up to 30 m
    ASSERT_TRUE(WriteFileAtomic(dir.file("agent.yaml"), yaml, &error)) << error;
  }
  auto agent = [&](const std::string& out) {
    return RunCommand(std::string(CALIBD_AGENT_EXE) + " --quiet --once --calibrate-now --config " +
                      dir.file("agent.yaml") + " --lcm-url 'file://" + dir.file("s.lcmlog") +
                      "?speed=0' --publish-url 'file://" + dir.file(out) + "?mode=w'");
  };

  // First run: no stored calibration, the config's prior is 3 deg off: updated and committed.
  ASSERT_EQ(agent("out1.lcmlog"), 0);
  CalibrationStoreConfig store_config;
  store_config.directory = dir.file("store");
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(store_config, &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  const StoredCalibration stored = *store.current();
  const Pose truth = TruthExtrinsic(dir.file("truth.json"));
  const double rot_err = RotationAngle(stored.T_camera_lidar.linear(), truth.linear()) * kRad2Deg;
  const double trans_err = (stored.T_camera_lidar.translation() - truth.translation()).norm();
  std::printf("%s: stored calibration error %.4f deg, %.4f m, %d frames, %d boards\n",
              lidar.c_str(), rot_err, trans_err, stored.frames_used, stored.boards_used);
  EXPECT_LT(rot_err, 0.1);
  EXPECT_LT(trans_err, 0.015);
  // The session's predicted 99 % bound on its own error is stored with it, and holds the truth.
  std::printf("%s: error bound %.4f deg, %.4f m\n", lidar.c_str(), stored.rotation_bound_deg,
              stored.translation_bound_m);
  EXPECT_GT(stored.rotation_bound_deg, 0.0);
  EXPECT_GT(stored.translation_bound_m, 0.0);
  EXPECT_LT(rot_err, stored.rotation_bound_deg);
  EXPECT_LT(trans_err, stored.translation_bound_m);
  EXPECT_EQ(stored.version, 1);
  EXPECT_EQ(stored.verdict, "updated");
  EXPECT_EQ(stored.lidar_serial.rfind("LDR-", 0), 0u) << "serials come from sensor_info";
  // The commit wrote the exports next to the store (drivers/calibration_export.hpp).
  std::string text;
  ASSERT_TRUE(ReadWholeFile(dir.file("store/export/calibration.json"), &text, &error)) << error;
  const auto exported = nlohmann::json::parse(text);
  EXPECT_EQ(exported["camera_frame"], "camera");
  EXPECT_EQ(exported["lidar_frame"], "lidar");
  for (int r = 0; r < 4; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_EQ(exported["T_camera_lidar"]["matrix"][r][c].get<double>(),
                stored.T_camera_lidar.matrix()(r, c));
  EXPECT_TRUE(ReadWholeFile(dir.file("store/export/calib_velo_to_cam.txt"), &text, &error))
      << error;

  const Published first = ReadPublished(dir.file("out1.lcmlog"));
  EXPECT_GE(first.status, 2);
  EXPECT_EQ(first.results, 1);
  EXPECT_EQ(first.last_result.verdict, +calibration_result_t::VERDICT_UPDATED);
  EXPECT_NEAR(first.last_result.delta_rotation_deg, 3.0, 0.2);
  EXPECT_NEAR(first.last_result.T_camera_lidar[3], stored.T_camera_lidar.translation().x(), 1e-9);
  EXPECT_EQ(first.last_result.rotation_bound_deg, stored.rotation_bound_deg);
  EXPECT_EQ(first.last_result.translation_bound_m, stored.translation_bound_m);
  EXPECT_EQ(first.last_status.state, +calibration_status_t::STATE_DONE);
  EXPECT_FLOAT_EQ(first.last_status.progress, 1.0f);
  EXPECT_GE(first.last_status.frames_used, 50);
  EXPECT_GE(first.health, 1);

  // Second run on the same data: the stored calibration is the prior now and is confirmed.
  ASSERT_EQ(agent("out2.lcmlog"), 0);
  ASSERT_TRUE(store.Open(store_config, &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 1);  // kept, not replaced
  EXPECT_GT(store.current()->verified_unix_s, 0);
  const Published second = ReadPublished(dir.file("out2.lcmlog"));
  EXPECT_EQ(second.last_result.verdict, +calibration_result_t::VERDICT_VERIFIED);
  EXPECT_EQ(second.last_health.calibration_state, +health_t::CALIB_VALID);
  // Without agent.can: no CAN link and no DTCs reported.
  EXPECT_EQ(second.last_health.can_state, "off");
  EXPECT_EQ(second.last_health.num_active_dtcs, 0);
}

INSTANTIATE_TEST_SUITE_P(EachLidar, AgentReplayTest, ::testing::Values("ot128", "m1", "falcon"));

TEST(AgentCliTest, BadConfigExitsWithTwoAndNamesTheKey) {
  testing::TempDir dir;
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --frames 1 --out " +
                       dir.file("one.lcmlog") + " --config-out " + dir.file("good.yaml")),
            0);
  std::string yaml, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("good.yaml"), &yaml, &error)) << error;
  const std::string log = dir.file("err.txt");
  auto agent_exit = [&](const std::string& extra) {
    EXPECT_TRUE(WriteFileAtomic(dir.file("bad.yaml"), yaml + extra, &error)) << error;
    return RunCommand(std::string(CALIBD_AGENT_EXE) + " --config " + dir.file("bad.yaml") + " 2> " +
                      log);
  };
  auto message = [&] {
    std::string text;
    EXPECT_TRUE(ReadWholeFile(log, &text, &error)) << error;
    return text;
  };
  EXPECT_EQ(agent_exit("agent:\n  max_frames: 3\n"), 2);
  EXPECT_NE(message().find("agent.max_frames"), std::string::npos) << message();
  EXPECT_EQ(agent_exit("agent:\n  max_frame: 300\n"), 2);  // a typo is named, not ignored
  EXPECT_NE(message().find("agent.max_frame"), std::string::npos) << message();
  // A store directory that cannot be created: refuses to start (exit 1), saying which.
  EXPECT_EQ(agent_exit("agent:\n  store:\n    directory: " + dir.file("one.lcmlog") + "/x\n"), 1);
  EXPECT_NE(message().find("one.lcmlog"), std::string::npos) << message();
  EXPECT_EQ(RunCommand(std::string(CALIBD_AGENT_EXE) + " --no-such-option 2>/dev/null"), 2);
  EXPECT_EQ(RunCommand(std::string(CALIBD_AGENT_EXE) + " --help >/dev/null"), 0);
}

TEST(AgentCliTest, AReplayWithDebugWritesWhatTheDetectorsMadeOfEachPair) {
  // Four still frame pairs of an OS1-64 with the default three boards, replayed with --debug: one
  // JSON file and one picture per pair, as calibd-calibrate --debug writes them.
  testing::TempDir dir;
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) +
                       " --quiet --lidar os1-64 --trajectory static --static-distance 8 --frames 4"
                       " --out " +
                       dir.file("s.lcmlog") + " --config-out " + dir.file("agent.yaml")),
            0);
  std::string yaml, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("agent.yaml"), &yaml, &error)) << error;
  yaml += "agent:\n  store:\n    directory: " + dir.file("store") + "\n";
  ASSERT_TRUE(WriteFileAtomic(dir.file("agent.yaml"), yaml, &error)) << error;
  const std::string agent = std::string(CALIBD_AGENT_EXE) + " --quiet --once --calibrate-now" +
                            " --config " + dir.file("agent.yaml") + " --debug " + dir.file("dbg");
  // Four pairs are too few for a session (it fails, 4): the debug files are what this is about.
  EXPECT_EQ(RunCommand(agent + " --lcm-url 'file://" + dir.file("s.lcmlog") + "?speed=0'"), 4);
  for (int pair = 0; pair < 4; ++pair) {
    char name[32];
    std::snprintf(name, sizeof(name), "dbg/pair_%06d", pair);
    std::string text;
    ASSERT_TRUE(ReadWholeFile(dir.file(name) + ".json", &text, &error)) << error;
    const auto debug = nlohmann::json::parse(text);
    EXPECT_EQ(debug["pair"], pair);
    EXPECT_EQ(debug["camera"]["boards"].size(), 3u) << text;
    EXPECT_GE(debug["lidar"]["boards"].get<int>(), 1) << text;
    EXPECT_GT(debug["lidar"]["clusters"].size(), debug["lidar"]["boards"].get<size_t>()) << text;
    std::string png;
    ASSERT_TRUE(ReadWholeFile(dir.file(name) + ".png", &png, &error)) << error;
    EXPECT_EQ(png.substr(1, 3), "PNG");
  }
  // Not on a vehicle's bus: two files a frame are for replays.
  EXPECT_EQ(RunCommand(agent + " --lcm-url 'udpm://239.255.76.67:7667?ttl=0' 2>/dev/null"), 2);
}

}  // namespace
}  // namespace calibd
