// Recorded data in, end to end: the short simulated session of test_calibrate_cli written out as
// a folder of PCD clouds (binary_compressed, with ring and per-point time) and PNG/JPEG images
// with a frames.csv, then calibrated with calibd-calibrate --folder (intrinsics from a ROS
// camera_info file) and through calibd-import + calibd-calibrate --log: both near the truth, and
// the same result.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>
#include <sstream>

#include "agent_outputs.hpp"
#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "json_file.hpp"
#include "pcd_writer.hpp"
#include "run_command.hpp"
#include "short_session.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

int RunCommand(const std::string& cmd) { return testing::RunCommand(cmd + " >/dev/null 2>&1"); }

using testing::ReadJson;

// Writes the log's frames into `dir`: frame k as k.pcd and k.png (even k) or k.jpg (odd k, the
// log's JPEG bytes as they are), and frames.csv with the log's times. The LiDAR's sweep start is
// its message utime (the log event comes at the sweep's end). Returns the number of frame pairs.
int ExportFolder(const std::string& log_path, const std::string& dir) {
  lcm::LogFile log(log_path, "r");
  EXPECT_TRUE(log.good());
  std::ofstream csv(dir + "/frames.csv");
  csv << "time_us,sensor,file\n";
  int cameras = 0, lidars = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == channels::kCamera.name) {
      camera_frame_t m;
      EXPECT_GE(m.decode(ev->data, 0, static_cast<int>(ev->datalen)), 0);
      EXPECT_EQ(m.encoding, +camera_frame_t::ENCODING_JPEG);
      const std::string stem = std::to_string(cameras++);
      std::string file;
      if (cameras % 2 == 1) {
        file = stem + ".png";
        const cv::Mat grey = cv::imdecode(m.data, cv::IMREAD_GRAYSCALE);
        EXPECT_TRUE(cv::imwrite(dir + "/" + file, grey));
      } else {
        file = stem + ".jpg";
        std::ofstream(dir + "/" + file, std::ios::binary)
            .write(reinterpret_cast<const char*>(m.data.data()),
                   static_cast<std::streamsize>(m.data.size()));
      }
      csv << m.utime << ",camera," << file << "\n";
    } else if (ev->channel == channels::kLidar.name) {
      lidar_frame_t m;
      EXPECT_GE(m.decode(ev->data, 0, static_cast<int>(ev->datalen)), 0);
      testing::PcdSpec s;
      s.fields = {{"x", 'F', 4, 1},         {"y", 'F', 4, 1},    {"z", 'F', 4, 1},
                  {"intensity", 'F', 4, 1}, {"ring", 'U', 2, 1}, {"t", 'U', 4, 1}};
      s.rows.reserve(static_cast<size_t>(m.num_points));
      for (int i = 0; i < m.num_points; ++i)
        s.rows.push_back({m.x[i], m.y[i], m.z[i], m.intensity[i], static_cast<double>(m.ring[i]),
                          m.time_offset_us[i] * 1000.0});  // Ouster-style ns
      const std::string file = std::to_string(lidars++) + ".pcd";
      std::ofstream(dir + "/" + file, std::ios::binary)
          << testing::WritePcd(s, "binary_compressed");
      csv << m.utime << ",lidar," << file << "\n";
    }
  }
  EXPECT_EQ(cameras, lidars);
  return lidars;
}

std::string RosCameraInfo(const CameraIntrinsics& c) {
  std::ostringstream o;
  o << std::setprecision(17) << "image_width: " << c.width << "\nimage_height: " << c.height
    << "\ncamera_name: front\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: [" << c.fx << ", 0, "
    << c.cx << ", 0, " << c.fy << ", " << c.cy << ", 0, 0, 1]\ndistortion_model: plumb_bob\n"
    << "distortion_coefficients:\n  rows: 1\n  cols: 5\n  data: [" << c.k1 << ", " << c.k2 << ", "
    << c.p1 << ", " << c.p2 << ", " << c.k3 << "]\n";
  return o.str();
}

TEST(RecordedFolderCliTest, FolderAndImportedLogCalibrateNearTheTruth) {
  testing::TempDir dir;
  // test_calibrate_cli's session: 40 frame pairs, 6-30 m, prior 4 deg / 4 cm off.
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --seed 5 --lidar ot128 --rate 2 " +
                       "--prior-rot-deg 4 --prior-trans-m 0.04 --image-encoding jpeg --out " +
                       dir.file("s.lcmlog") + " --truth " + dir.file("truth.json") +
                       " --config-out " + dir.file("calib.yaml")),
            0);
  std::filesystem::create_directories(dir.file("rec"));
  ASSERT_EQ(ExportFolder(dir.file("s.lcmlog"), dir.file("rec")), 40);
  std::filesystem::remove(dir.file("s.lcmlog"));  // 250 MB

  // The intrinsics come from a camera_info file; the config's camera is spoilt to show they do.
  CalibConfig config;
  std::string error;
  ASSERT_TRUE(LoadConfigFile(dir.file("calib.yaml"), &config, &error)) << error;
  ASSERT_TRUE(WriteFileAtomic(dir.file("camera_info.yaml"), RosCameraInfo(config.camera), &error));
  CalibConfig spoilt = config;
  spoilt.camera.fx *= 1.05;
  ASSERT_TRUE(SaveConfigFile(dir.file("spoilt.yaml"), spoilt, &error)) << error;
  // 40 pairs of boards ahead at up to 30 m: the short session's translation tolerance.
  std::ofstream(dir.file("spoilt.yaml"), std::ios::app) << testing::ShortSessionEngineYaml();

  const std::string calibrate =
      std::string(CALIBD_CALIBRATE_EXE) + " --truth " + dir.file("truth.json") + " --intrinsics " +
      dir.file("camera_info.yaml") + " --config " + dir.file("spoilt.yaml");
  const int code = RunCommand(calibrate + " --folder " + dir.file("rec") + " --report " +
                              dir.file("folder.json"));
  const auto folder = ReadJson(dir.file("folder.json"));
  EXPECT_EQ(code, 0) << folder.dump(2);
  EXPECT_EQ(folder["verdict"], "updated") << folder["reason"] << ": " << folder["detail"];
  EXPECT_LT(folder["error_vs_truth"]["rotation_deg"].get<double>(), 0.15);
  EXPECT_LT(folder["error_vs_truth"]["translation_m"].get<double>(), 0.02);
  EXPECT_EQ(folder["frames"]["pairs"].get<int>(), 40);
  EXPECT_EQ(folder["frames"]["bad_messages"].get<int>(), 0) << folder["frames"];
  EXPECT_EQ(folder["frames"]["unpaired_camera"].get<int>(), 0);

  // --inspect, as a new user without a config: the tags, the LiDAR model and a starter config
  // that, once its TODOs are measured, reads back with the session's boards and model.
  ASSERT_EQ(testing::RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --inspect --folder " +
                                dir.file("rec") + " --intrinsics " + dir.file("camera_info.yaml") +
                                " --write-config " + dir.file("starter.yaml") + " > " +
                                dir.file("inspect.txt") + " 2>&1"),
            0);
  std::string table, starter;
  ASSERT_TRUE(ReadWholeFile(dir.file("inspect.txt"), &table, &error)) << error;
  ASSERT_TRUE(ReadWholeFile(dir.file("starter.yaml"), &starter, &error)) << error;
  for (const BoardGeometry& g : config.boards)
    EXPECT_NE(table.find("tag " + g.tag_family + " id " + std::to_string(g.tag_id) + " ("),
              std::string::npos)
        << table;
  EXPECT_NE(table.find("128 rings"), std::string::npos) << table;
  EXPECT_NE(table.find("model ot128"), std::string::npos) << table;
  ConfigParseOptions with_intrinsics;
  with_intrinsics.intrinsics = &config.camera;
  CalibConfig unmeasured;
  EXPECT_FALSE(ParseConfigYaml(starter, &unmeasured, &error, with_intrinsics));  // TODOs refuse
  EXPECT_NE(error.find("width_m"), std::string::npos) << error;
  // The tape measure: every board's sizes, and the lever arm.
  ASSERT_EQ(starter.find("checkerboard"), std::string::npos) << starter;
  ASSERT_FALSE(config.boards.empty());
  for (const char* key : {"width_m: TODO", "height_m: TODO", "tag_size_m: TODO"}) {
    const std::string k(key);
    const std::string value =
        k.rfind("tag_size", 0) == 0 ? ShortestDecimal(config.boards[0].tag_size_m)
        : k.rfind("width", 0) == 0  ? ShortestDecimal(config.boards[0].width_m)
                                    : ShortestDecimal(config.boards[0].height_m);
    for (size_t at = starter.find(k); at != std::string::npos; at = starter.find(k))
      starter.replace(at, k.size(), k.substr(0, k.size() - 4) + value);
  }
  CalibConfig measured;
  ASSERT_TRUE(ParseConfigYaml(starter, &measured, &error, with_intrinsics)) << error << "\n"
                                                                            << starter;
  EXPECT_EQ(measured.lidar_model, "ot128");
  ASSERT_EQ(measured.boards.size(), config.boards.size()) << starter;
  for (size_t b = 0; b < config.boards.size(); ++b) {
    EXPECT_EQ(measured.boards[b].tag_family, config.boards[b].tag_family);
    EXPECT_EQ(measured.boards[b].tag_id, config.boards[b].tag_id);
  }
  // The nominal prior of the forward mounting: within the grid search's reach of the truth.
  EXPECT_LT(RotationAngle(measured.prior_T_camera_lidar.linear(),
                          testing::TruthExtrinsic(dir.file("truth.json")).linear()) *
                180.0 / M_PI,
            10.0);

  // calibd-import: the same folder as a log, replayed by calibd-calibrate --log.
  ASSERT_EQ(RunCommand(std::string(CALIBD_IMPORT_EXE) + " --folder " + dir.file("rec") +
                       " --config " + dir.file("spoilt.yaml") + " --intrinsics " +
                       dir.file("camera_info.yaml") + " --out " + dir.file("imported.lcmlog") +
                       " --config-out " + dir.file("imported.yaml")),
            0);
  CalibConfig imported;
  ASSERT_TRUE(LoadConfigFile(dir.file("imported.yaml"), &imported, &error)) << error;
  EXPECT_EQ(imported.camera.fx, config.camera.fx);  // --config-out carries the intrinsics
  std::ofstream(dir.file("imported.yaml"), std::ios::app) << testing::ShortSessionEngineYaml();
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --truth " + dir.file("truth.json") +
                       " --config " + dir.file("imported.yaml") + " --log " +
                       dir.file("imported.lcmlog") + " --report " + dir.file("log.json")),
            0);
  const auto log = ReadJson(dir.file("log.json"));
  EXPECT_EQ(log["frames"]["pairs"].get<int>(), 40);
  // Same pixels (the same decoder), same points, same times: the same result.
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      EXPECT_NEAR(log["T_camera_lidar"]["matrix"][r][c].get<double>(),
                  folder["T_camera_lidar"]["matrix"][r][c].get<double>(), 1e-9)
          << r << "," << c;

  // The agent replays the imported log as if the frames came live and commits its calibration
  // (its collection gates lowered to the 40 recorded pairs).
  std::string yaml;
  ASSERT_TRUE(ReadWholeFile(dir.file("imported.yaml"), &yaml, &error)) << error;
  yaml += "agent:\n  auto_commit: true\n  min_frames: 30\n  store:\n    directory: " +
          dir.file("store") + "\n";
  ASSERT_TRUE(WriteFileAtomic(dir.file("agent.yaml"), yaml, &error)) << error;
  EXPECT_EQ(RunCommand(std::string(CALIBD_AGENT_EXE) + " --quiet --once --calibrate-now --config " +
                       dir.file("agent.yaml") + " --lcm-url 'file://" +
                       dir.file("imported.lcmlog") + "?speed=0'"),
            0);
  std::string stored_text;
  ASSERT_TRUE(ReadWholeFile(dir.file("store/export/calibration.json"), &stored_text, &error))
      << error;
  const auto stored = nlohmann::json::parse(stored_text);
  const Pose truth = testing::TruthExtrinsic(dir.file("truth.json"));
  Pose T_stored = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c)
      T_stored.matrix()(r, c) = stored["T_camera_lidar"]["matrix"][r][c].get<double>();
  const double rot_err_deg = RotationAngle(T_stored.linear(), truth.linear()) * 180.0 / M_PI;
  const double trans_err_m = (T_stored.translation() - truth.translation()).norm();
  std::printf("agent on the imported log: %.4f deg, %.4f m from the truth\n", rot_err_deg,
              trans_err_m);
  EXPECT_LT(rot_err_deg, 0.15);
  EXPECT_LT(trans_err_m, 0.02);
}

TEST(RecordedFolderCliTest, StemPairsBadFilesAndExitCodes) {
  testing::TempDir dir;
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) +
                       " --quiet --trajectory static --frames 1 --out " + dir.file("one.lcmlog") +
                       " --config-out " + dir.file("calib.yaml") + " --image-encoding jpeg"),
            0);
  const std::string rec = dir.file("rec");
  std::filesystem::create_directories(rec);
  ASSERT_EQ(ExportFolder(dir.file("one.lcmlog"), rec), 1);
  std::filesystem::remove(rec + "/frames.csv");  // pair by stem: 0.pcd + 0.png
  // A malformed cloud with its own image: counted as a bad message, the good pair calibrates
  // (and is rejected as too few boards: exit 3).
  std::ofstream(rec + "/1.pcd") << "VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\nWIDTH 1\n"
                                   "HEIGHT 1\nPOINTS 1\nDATA ascii\n1 2\n";
  std::filesystem::copy_file(rec + "/0.png", rec + "/1.png");
  std::ofstream(rec + "/2.pcd") << "only a cloud";  // no partner: not read
  const std::string calibrate = std::string(CALIBD_CALIBRATE_EXE) + " --config " +
                                dir.file("calib.yaml") + " --report " + dir.file("r.json");
  EXPECT_EQ(RunCommand(calibrate + " --folder " + rec), 3);
  const auto report = ReadJson(dir.file("r.json"));
  EXPECT_EQ(report["reason"], "too_few_boards");
  EXPECT_EQ(report["frames"]["pairs"].get<int>(), 1);
  EXPECT_EQ(report["frames"]["bad_messages"].get<int>(), 1);
  EXPECT_EQ(report["frames"]["unmatched_clouds"].get<int>(), 1);
  EXPECT_NE(
      report["frames"]["first_bad_message"].get<std::string>().find("1.pcd: field 'z' is missing"),
      std::string::npos)
      << report["frames"];

  const std::string import = std::string(CALIBD_IMPORT_EXE) + " --config " +
                             dir.file("calib.yaml") + " --out " + dir.file("o.lcmlog");
  EXPECT_EQ(RunCommand(std::string(CALIBD_IMPORT_EXE) + " --help"), 0);
  EXPECT_EQ(RunCommand(import), 2);  // no --folder
  EXPECT_EQ(RunCommand(import + " --folder " + rec + " --bogus 1"), 2);
  EXPECT_EQ(RunCommand(import + " --folder " + rec + " --intrinsics /nonexistent.yaml"), 2);
  EXPECT_EQ(RunCommand(import + " --folder " + rec), 1);  // the malformed 1.pcd stops it
  EXPECT_EQ(RunCommand(import + " --folder /nonexistent"), 1);
  std::filesystem::remove(rec + "/1.pcd");
  EXPECT_EQ(RunCommand(import + " --folder " + rec), 0);
  EXPECT_EQ(RunCommand(calibrate + " --folder /nonexistent"), 1);
  EXPECT_EQ(RunCommand(calibrate + " --folder " + rec + " --log x.lcmlog"), 2);  // not both
  EXPECT_EQ(RunCommand(calibrate + " --folder " + rec + " --intrinsics /nonexistent.yaml"), 2);
  // lidar.model generic without lidar.generic values: the scan geometry is estimated from the
  // folder's clouds (as from a log's first frames).
  std::string yaml, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("calib.yaml"), &yaml, &error)) << error;
  const size_t model_at = yaml.find("model: ot128");
  ASSERT_NE(model_at, std::string::npos) << yaml;
  yaml.replace(model_at, 12, "model: generic");
  ASSERT_TRUE(WriteFileAtomic(dir.file("generic.yaml"), yaml, &error)) << error;
  EXPECT_EQ(testing::RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --config " +
                                dir.file("generic.yaml") + " --folder " + rec +
                                " 2>&1 | grep -q 'generic LiDAR: azimuth'"),
            0);
  // Every cloud malformed: the verdict says the LiDAR's frames are the cause, with the first
  // error, not that the camera saw no board.
  const std::string bad = dir.file("bad");
  std::filesystem::create_directories(bad);
  for (const char* stem : {"0", "1"}) {
    std::ofstream(bad + "/" + stem + ".pcd") << "VERSION 0.7\nFIELDS x y\nSIZE 4 4\nTYPE F F\n"
                                                "WIDTH 1\nHEIGHT 1\nPOINTS 1\nDATA ascii\n1 2\n";
    std::filesystem::copy_file(rec + "/0.png", bad + "/" + stem + ".png");
  }
  EXPECT_EQ(RunCommand(calibrate + " --folder " + bad), 3);
  const auto all_bad = ReadJson(dir.file("r.json"));
  EXPECT_EQ(all_bad["reason"], "no_lidar_boards");
  EXPECT_NE(all_bad["detail"].get<std::string>().find(
                "every one of the 2 LiDAR frames of this folder is malformed; the first: "),
            std::string::npos)
      << all_bad["detail"];
  EXPECT_NE(all_bad["detail"].get<std::string>().find("0.pcd: field 'z' is missing"),
            std::string::npos)
      << all_bad["detail"];
  // A log of random bytes holds no frames, and says so.
  {
    std::ofstream noise(dir.file("noise.lcmlog"), std::ios::binary);
    uint32_t x = 12345;
    for (int i = 0; i < 65536; ++i) {
      x = x * 1664525u + 1013904223u;  // any bytes will do: a linear congruential sequence
      noise.put(static_cast<char>(x >> 24));
    }
  }
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --config " + dir.file("calib.yaml") +
                       " --report " + dir.file("r.json") + " --log " + dir.file("noise.lcmlog")),
            3);
  const auto noise = ReadJson(dir.file("r.json"));
  EXPECT_EQ(noise["reason"], "no_camera_boards");
  EXPECT_EQ(noise["detail"].get<std::string>().rfind("no frames in this log: ", 0), 0u)
      << noise["detail"];

  // A frames.csv names its bad line.
  std::ofstream(rec + "/frames.csv") << "time_us,sensor,file\n100,radar,0.pcd\n";
  EXPECT_EQ(RunCommand(calibrate + " --folder " + rec), 1);
  EXPECT_EQ(testing::RunCommand(calibrate + " --folder " + rec + " 2>&1 | grep -q " +
                                "'frames.csv: line 2: sensor must be lidar or camera'"),
            0);
}

TEST(RecordedFolderCliTest, TheSimulatorWritesFoldersThatCalibrateReads) {
  // calibd-sim --folder, with frames.csv and without (pairs by name), a sensor with rings and one
  // without: every pair read back, no file refused, the ring field only where there are rings.
  testing::TempDir dir;
  for (const std::string lidar : {"vlp16", "avia"}) {
    for (const bool csv : {true, false}) {
      const std::string rec = dir.file(lidar + (csv ? "-csv" : "-stems"));
      ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --lidar " + lidar +
                           " --trajectory stills --rate 0.5 --frames 3 --folder " + rec +
                           (csv ? "" : " --no-frames-csv") + " --config-out " + dir.file("c.yaml") +
                           (csv ? "" : " --image-encoding jpeg")),
                0);
      EXPECT_EQ(std::filesystem::exists(rec + "/frames.csv"), csv);
      EXPECT_TRUE(std::filesystem::exists(rec + (csv ? "/000002.png" : "/000002.jpg")));
      std::string pcd, error;
      ASSERT_TRUE(ReadWholeFile(rec + "/000000.pcd", &pcd, &error)) << error;
      EXPECT_EQ(pcd.find("FIELDS x y z intensity ring t") != std::string::npos, lidar == "vlp16")
          << pcd.substr(0, 200);
      EXPECT_NE(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --folder " + rec + " --config " +
                           dir.file("c.yaml") + " --report " + dir.file("r.json")),
                1);
      const auto report = ReadJson(dir.file("r.json"));
      EXPECT_EQ(report["frames"]["pairs"].get<int>(), 3) << lidar << " " << report["frames"];
      EXPECT_EQ(report["frames"]["bad_messages"].get<int>(), 0) << report["frames"];
      EXPECT_GT(report["frames"]["camera_boards"].get<int>(), 0) << report["frames"];
      // Pairs 2 s apart (frames.csv) are beyond the velocity window: the report says so, with the
      // window to set if the boards moved; name-stem pairs carry made-up times and say nothing.
      const auto& motion = report["motion_compensation"];
      EXPECT_NEAR(motion["frame_interval_s"].get<double>(), csv ? 2.0 : 0.0, 1e-6) << motion;
      EXPECT_EQ(report.contains("motion_compensation_hint"), csv) << report.dump(1);
      // --inspect names the model from the rings it sees (some of the VLP-16's see nothing
      // indoors), and has no ring to go by for the Avia-like sensor.
      ASSERT_EQ(testing::RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --inspect --folder " +
                                    rec + " > " + dir.file("inspect.txt") + " 2>&1"),
                0);
      std::string table;
      ASSERT_TRUE(ReadWholeFile(dir.file("inspect.txt"), &table, &error)) << error;
      EXPECT_NE(table.find(lidar == "vlp16" ? "model vlp16" : "no ring field"), std::string::npos)
          << table;
      EXPECT_NE(table.find("lidar:\n  id: lidar\n  model: " +
                           std::string(lidar == "vlp16" ? "vlp16" : "generic")),
                std::string::npos)
          << table;
    }
  }
}

TEST(RecordedFolderCliTest, StillPosesRecordedAsAStreamByARosetteCalibrateNearTheTruth) {
  // 12 poses of a Livox-Avia-like rosette, 5 sweeps each (calibd-sim --frames-per-pose), as Livox
  // users record: a sweep alone can cover too little of a board to pass the detector's gates,
  // but a pose's board is found in some of its sweeps, each paired with its own image.
  testing::TempDir dir;
  const std::string rec = dir.file("stream");
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) +
                       " --quiet --lidar avia --trajectory stills --rate 0.5 --frames 12"
                       " --frames-per-pose 5 --still-distance 2,6 --boards 1 --board-size 0.9"
                       " --tag-size 0.7 --width 1920 --height 1200 --fx 1100 --fy 1100"
                       " --folder " +
                       rec + " --truth " + dir.file("truth.json") + " --config-out " +
                       dir.file("c.yaml")),
            0);
  // Five frames 0.1 s apart per pose, the poses 2 s apart.
  const auto truth = ReadJson(dir.file("truth.json"));
  ASSERT_EQ(truth["frames"].size(), 60u);
  const auto utime = [&](int k) { return truth["frames"][k]["camera_utime"].get<int64_t>(); };
  EXPECT_EQ(utime(4) - utime(0), 400000);
  EXPECT_EQ(utime(5) - utime(0), 2000000);
  ASSERT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --quiet --folder " + rec +
                       " --config " + dir.file("c.yaml") + " --truth " + dir.file("truth.json") +
                       " --report " + dir.file("r.json")),
            0);
  const auto report = ReadJson(dir.file("r.json"));
  EXPECT_EQ(report["verdict"].get<std::string>(), "updated") << report["detail"];
  EXPECT_LT(report["error_vs_truth"]["rotation_deg"].get<double>(), 0.1);
  EXPECT_LT(report["error_vs_truth"]["translation_m"].get<double>(), 0.01);
  // Single sweeps missed in a stream are no reason for a hint: other sweeps found the board.
  EXPECT_FALSE(report.contains("hint")) << report["hint"];

  // One sweep per pose of a sparser Mid-360-like sensor: the LiDAR misses many of the boards
  // the camera saw, and the report says what to record instead.
  const std::string stills = dir.file("stills");
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) +
                       " --quiet --lidar mid360 --trajectory stills --rate 0.5 --frames 12"
                       " --still-distance 3,6 --boards 1 --board-size 0.9 --tag-size 0.7"
                       " --width 1920 --height 1200 --fx 1100 --fy 1100 --folder " +
                       stills + " --config-out " + dir.file("m.yaml")),
            0);
  RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --quiet --folder " + stills + " --config " +
             dir.file("m.yaml") + " --report " + dir.file("m.json"));
  const auto single = ReadJson(dir.file("m.json"));
  ASSERT_TRUE(single.contains("hint")) << single["frames"];
  EXPECT_NE(single["hint"].get<std::string>().find("record about a second of sweeps per pose"),
            std::string::npos)
      << single["hint"];
}

}  // namespace
}  // namespace calibd
