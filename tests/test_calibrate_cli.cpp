// calibd-calibrate end to end: a short simulated session through the real programs (simulator,
// then calibrator reading the LCM log and the config), checked against the simulator's truth.

#include <gtest/gtest.h>

#include <cstdlib>
#include <fstream>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "json_file.hpp"
#include "run_command.hpp"
#include "short_session.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

// Quietly: the programs' own output is not part of what these tests check.
int RunCommand(const std::string& cmd) { return testing::RunCommand(cmd + " >/dev/null 2>&1"); }

using testing::ReadJson;

TEST(CalibrateCliTest, ShortDriveIsCalibratedNearTheTruth) {
  testing::TempDir dir;
  // The default 20 s drive (6-30 m and back) sampled at 2 Hz: 40 frame pairs; prior 4 deg / 4 cm
  // off.
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --seed 5 --lidar ot128 --rate 2 " +
                       "--prior-rot-deg 4 --prior-trans-m 0.04 --image-encoding jpeg" + " --out " +
                       dir.file("s.lcmlog") + " --truth " + dir.file("truth.json") +
                       " --config-out " + dir.file("calib.yaml")),
            0);
  std::ofstream(dir.file("calib.yaml"), std::ios::app) << testing::ShortSessionEngineYaml();
  const int code =
      RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log " + dir.file("s.lcmlog") +
                 " --config " + dir.file("calib.yaml") + " --truth " + dir.file("truth.json") +
                 " --report " + dir.file("report.json") + " --export " + dir.file("export") +
                 " --html " + dir.file("report.html"));
  const auto report = ReadJson(dir.file("report.json"));
  EXPECT_EQ(code, 0) << report.dump(2);
  EXPECT_EQ(report["verdict"], "updated") << report["reason"] << ": " << report["detail"];
  EXPECT_NEAR(report["delta_vs_prior"]["rotation_deg"].get<double>(), 4.0, 0.3);
  EXPECT_LT(report["error_vs_truth"]["rotation_deg"].get<double>(), 0.15);
  EXPECT_LT(report["error_vs_truth"]["translation_m"].get<double>(), 0.02);
  EXPECT_EQ(report["frames"]["pairs"].get<int>(), 40);
  EXPECT_EQ(report["frames"]["unpaired_camera"].get<int>(), 0);
  EXPECT_GT(report["board_pose_refinement"]["refined_boards"].get<int>(), 60);
  // --export: the same transform as the report, with the config's frame names (the formats
  // themselves are test_calibration_export's).
  const auto exported = ReadJson(dir.file("export/calibration.json"));
  EXPECT_EQ(exported["camera_frame"], "camera");
  EXPECT_EQ(exported["lidar_frame"], "lidar");
  EXPECT_EQ(exported["software_version"], report["software_version"]);
  EXPECT_EQ(exported["T_camera_lidar"], report["T_camera_lidar"]);
  EXPECT_EQ(exported["T_lidar_camera"], report["T_lidar_camera"]);
  for (const char* name :
       {"T_camera_lidar_opencv.yaml", "ros_static_transform_publisher.txt",
        "T_camera_lidar_tf.yaml", "sensor_kit_calibration.yaml", "calib_velo_to_cam.txt"}) {
    std::string text, error;
    EXPECT_TRUE(ReadWholeFile(dir.file("export/") + name, &text, &error)) << error;
  }
  // --html: the page for people (its content is test_html_report's, its rendering
  // test_html_report_browser's): the verdict, both plots, the 4 overlay pictures, nothing fetched.
  std::string html, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("report.html"), &html, &error)) << error;
  EXPECT_NE(html.find("<p class=\"word\">UPDATED</p>"), std::string::npos);
  EXPECT_NE(html.find("id=\"per-distance\"><h2>"), std::string::npos);
  size_t pictures = 0;
  for (size_t at = html.find("src=\"data:image/png;base64,"); at != std::string::npos;
       at = html.find("src=\"data:image/png;base64,", at + 1))
    ++pictures;
  EXPECT_EQ(pictures, 4u);
  EXPECT_EQ(html.find("http://"), std::string::npos);
  EXPECT_EQ(html.find("https://"), std::string::npos);
}

// Board geometry from the config: three rectangular 0.8 x 0.6 m boards, the middle one
// printed with a 5 x 7 inner-corner checkerboard, the others with AprilTags. The checkerboard's
// detections are counted: more camera boards than the two tag boards can give.
TEST(CalibrateCliTest, RectangularTagAndCheckerboardBoardsAreCalibrated) {
  testing::TempDir dir;
  ASSERT_EQ(RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --seed 8 --lidar ot128 --rate 2 " +
                       "--boards 3 --board-size 0.8,0.6 --tag-size 0.5 --checkerboard 1,5,7,0.08 " +
                       "--prior-rot-deg 3 --prior-trans-m 0.05 --image-encoding jpeg --out " +
                       dir.file("s.lcmlog") + " --truth " + dir.file("truth.json") +
                       " --config-out " + dir.file("calib.yaml")),
            0);
  std::string config, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("calib.yaml"), &config, &error)) << error;
  EXPECT_NE(config.find("pattern: checkerboard"), std::string::npos) << config;
  const int code = RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log " + dir.file("s.lcmlog") +
                              " --config " + dir.file("calib.yaml") + " --truth " +
                              dir.file("truth.json") + " --report " + dir.file("report.json"));
  const auto report = ReadJson(dir.file("report.json"));
  EXPECT_EQ(code, 0) << report.dump(2);
  EXPECT_EQ(report["verdict"], "updated") << report["reason"] << ": " << report["detail"];
  EXPECT_LT(report["error_vs_truth"]["rotation_deg"].get<double>(), 0.2);
  EXPECT_LT(report["error_vs_truth"]["translation_m"].get<double>(), 0.02);
  const int pairs = report["frames"]["pairs"].get<int>();
  EXPECT_EQ(pairs, 40);
  EXPECT_GT(report["frames"]["camera_boards"].get<int>(), 2 * pairs + 20);  // >= 21 checkerboards
}

TEST(CalibrateCliTest, BadInputsGiveClearExitCodes) {
  testing::TempDir dir;
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --help"), 0);
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log x.lcmlog"), 2);  // no --config
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log x --config /nonexistent.yaml"),
            2);
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log x --config y --method magic"),
            2);
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) +
                       " --log x --config y --board-pose-refinement maybe"),
            2);
  ASSERT_EQ(
      RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --trajectory static --frames 1 --out " +
                 dir.file("one.lcmlog") + " --config-out " + dir.file("calib.yaml")),
      0);
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log /nonexistent.lcmlog --config " +
                       dir.file("calib.yaml")),
            1);
  // One frame pair of three boards is far too little: rejected (exit 3) with the reason in the
  // report.
  EXPECT_EQ(RunCommand(std::string(CALIBD_CALIBRATE_EXE) + " --log " + dir.file("one.lcmlog") +
                       " --config " + dir.file("calib.yaml") + " --report " + dir.file("r.json") +
                       " --html " + dir.file("r.html")),
            3);
  EXPECT_EQ(ReadJson(dir.file("r.json"))["reason"], "too_few_boards");
  // The HTML report is written for a rejected result too, saying so.
  std::string html, error;
  ASSERT_TRUE(ReadWholeFile(dir.file("r.html"), &html, &error)) << error;
  EXPECT_NE(html.find("<p class=\"word\">REJECTED</p>"), std::string::npos);
  EXPECT_NE(html.find("<b>too_few_boards</b>"), std::string::npos);
}

TEST(CalibrateCliTest, TheConfigsEngineSectionAndIntrinsicsFromAFileAreRead) {
  testing::TempDir dir;
  ASSERT_EQ(
      RunCommand(std::string(CALIBD_SIM_EXE) + " --quiet --trajectory static --frames 1 --out " +
                 dir.file("one.lcmlog") + " --config-out " + dir.file("calib.yaml")),
      0);
  CalibConfig config;
  std::string error, text;
  ASSERT_TRUE(LoadConfigFile(dir.file("calib.yaml"), &config, &error)) << error;
  ASSERT_TRUE(ReadWholeFile(dir.file("calib.yaml"), &text, &error)) << error;
  const std::string calibrate = std::string(CALIBD_CALIBRATE_EXE) + " --log " +
                                dir.file("one.lcmlog") + " --report " + dir.file("r.json") +
                                " --config ";

  // The agent's engine section: its verdict gates apply (and an agent section is no error).
  ASSERT_TRUE(WriteFileAtomic(dir.file("engine.yaml"),
                              text + "agent:\n  min_frames: 30\nengine:\n  verdict:\n"
                                     "    min_boards: 2\n    min_frames: 2\n",
                              &error))
      << error;
  EXPECT_EQ(RunCommand(calibrate + dir.file("engine.yaml")), 3);
  const auto report = ReadJson(dir.file("r.json"));
  EXPECT_EQ(report["reason"], "too_few_frames");  // 1 frame pair, 2 needed: the config's gate
  EXPECT_NE(report["detail"].get<std::string>().find("2 needed"), std::string::npos);
  // A wrong key in it is refused, named.
  ASSERT_TRUE(WriteFileAtomic(dir.file("typo.yaml"),
                              text + "engine:\n  verdict:\n    min_bords: 2\n", &error))
      << error;
  EXPECT_EQ(testing::RunCommand(calibrate + dir.file("typo.yaml") + " >/dev/null 2>" +
                                dir.file("err.txt")),
            2);
  std::string err;
  ASSERT_TRUE(ReadWholeFile(dir.file("err.txt"), &err, &error)) << error;
  EXPECT_NE(err.find("engine.verdict.min_bords: unknown key (did you mean min_boards?)"),
            std::string::npos)
      << err;

  // With --intrinsics the camera section may hold only the camera's id.
  const CameraIntrinsics& k = config.camera;
  nlohmann::json intrinsics = {{"K", {k.fx, 0.0, k.cx, 0.0, k.fy, k.cy, 0.0, 0.0, 1.0}},
                               {"D", {k.k1, k.k2, k.p1, k.p2, k.k3}},
                               {"width", k.width},
                               {"height", k.height}};
  ASSERT_TRUE(WriteFileAtomic(dir.file("k.json"), intrinsics.dump(), &error)) << error;
  const size_t camera = text.find("camera:"), lidar = text.find("\nlidar:");
  ASSERT_NE(camera, std::string::npos);
  ASSERT_NE(lidar, std::string::npos);
  const std::string no_intrinsics =
      text.substr(0, camera) + "camera:\n  id: " + config.camera_id + text.substr(lidar);
  ASSERT_TRUE(WriteFileAtomic(dir.file("bare.yaml"), no_intrinsics, &error)) << error;
  EXPECT_EQ(RunCommand(calibrate + dir.file("bare.yaml")), 2);  // no intrinsics at all
  EXPECT_EQ(RunCommand(calibrate + dir.file("bare.yaml") + " --intrinsics " + dir.file("k.json")),
            3);  // read, calibrated, too little data
  EXPECT_EQ(ReadJson(dir.file("r.json"))["reason"], "too_few_boards");

  // --debug: what the detectors made of the pair, the LiDAR's clusters with their gates.
  EXPECT_EQ(RunCommand(calibrate + dir.file("calib.yaml") + " --debug " + dir.file("dbg/x")), 3);
  const auto debug = ReadJson(dir.file("dbg/x/pair_000000.json"));
  EXPECT_EQ(debug["pair"], 0);
  EXPECT_EQ(debug["camera"]["boards"].size(), 3u);  // the simulator's three boards
  for (const auto& b : debug["camera"]["boards"]) {
    EXPECT_EQ(b["corners_px"].size(), 4u);
    EXPECT_LT(b["reprojection_rms_px"].get<double>(), 1.0);
  }
  int boards = 0;
  for (const auto& c : debug["lidar"]["clusters"]) {
    boards += c["gate"] == "board" ? 1 : 0;
    EXPECT_GE(c["cells"].get<int>(), 8);
    if (c["gate"] == "board") {
      EXPECT_GE(c["descriptor_score"].get<double>(), 0.94);
    }
  }
  EXPECT_EQ(boards, debug["lidar"]["boards"].get<int>());
  EXPECT_GE(boards, 2);
  EXPECT_GT(debug["lidar"]["clusters"].size(), static_cast<size_t>(boards));  // the refused too
  // The range-image picture: the boards' cells in green, the refused clusters in their gates'
  // colours (the legend in the JSON).
  EXPECT_EQ(debug["lidar"]["picture"]["file"], "pair_000000.png");
  EXPECT_NE(debug["lidar"]["picture"]["colours"].get<std::string>().find("board (green)"),
            std::string::npos);
  const cv::Mat picture = cv::imread(dir.file("dbg/x/pair_000000.png"), cv::IMREAD_COLOR);
  ASSERT_FALSE(picture.empty());
  EXPECT_EQ(picture.cols, 1800);     // the OT128's columns
  EXPECT_EQ(picture.rows, 128 * 3);  // its rings, 3 px each
  int green = 0, refused = 0;
  for (int y = 0; y < picture.rows; ++y)
    for (int x = 0; x < picture.cols; ++x) {
      const cv::Vec3b p = picture.at<cv::Vec3b>(y, x);
      green += p == cv::Vec3b(60, 220, 60) ? 1 : 0;
      refused += p == cv::Vec3b(0, 150, 255) || p == cv::Vec3b(220, 60, 220) ||
                         p == cv::Vec3b(230, 120, 30) || p == cv::Vec3b(40, 40, 200)
                     ? 1
                     : 0;
    }
  EXPECT_GT(green, 100 * boards);
  EXPECT_GT(refused, 0);
}

}  // namespace
}  // namespace calibd
