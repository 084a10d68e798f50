// A short simulated session written to an LCM log and read back through LCM's file provider
// (the same path the agent replays from): counts, timestamps, and LiDAR board points on the true
// board plane within the noise.

#include <gtest/gtest.h>

#include <lcm/lcm-cpp.hpp>
#include <map>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "calibd/sensor_info_t.hpp"
#include "run.hpp"
#include "small_camera.hpp"
#include "temp_dir.hpp"
#include "truth_json.hpp"

namespace calibd::sim {
namespace {

struct Received {
  std::vector<calibd::camera_frame_t> cameras;
  std::vector<calibd::lidar_frame_t> lidars;
  std::vector<calibd::sensor_info_t> infos;

  void OnCamera(const lcm::ReceiveBuffer*, const std::string&, const calibd::camera_frame_t* m) {
    cameras.push_back(*m);
  }
  void OnLidar(const lcm::ReceiveBuffer*, const std::string&, const calibd::lidar_frame_t* m) {
    lidars.push_back(*m);
  }
  void OnInfo(const lcm::ReceiveBuffer*, const std::string&, const calibd::sensor_info_t* m) {
    infos.push_back(*m);
  }
};

Received ReadBack(const std::string& log_path) {
  Received r;
  lcm::LCM lcm("file://" + log_path + "?speed=0");
  EXPECT_TRUE(lcm.good());
  lcm.subscribe(std::string(channels::kCamera.name), &Received::OnCamera, &r);
  lcm.subscribe(std::string(channels::kLidar.name), &Received::OnLidar, &r);
  lcm.subscribe(std::string(channels::kSensorInfo.name), &Received::OnInfo, &r);
  // The file provider delivers events as fast as possible; a quiet second means the log ended.
  while (lcm.handleTimeout(1000) > 0) {
  }
  return r;
}

// The log's own event timestamps per channel (the file provider stamps deliveries with the replay
// clock, so these are read with LCM's log reader).
std::map<std::string, std::vector<int64_t>> EventTimes(const std::string& log_path) {
  std::map<std::string, std::vector<int64_t>> times;
  lcm::LogFile log(log_path, "r");
  EXPECT_TRUE(log.good());
  int64_t last = 0;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    EXPECT_GE(ev->timestamp, last) << "events must be in time order";
    last = ev->timestamp;
    times[ev->channel].push_back(ev->timestamp);
  }
  return times;
}

SessionOptions SmallSession(const std::string& lidar, const std::string& mode) {
  SessionOptions o;
  o.seed = 7;
  o.lidar_model = lidar;
  o.trajectory.mode = mode;
  o.trajectory.duration_s = 0.5;  // 5 frame pairs
  o.camera = testing::SmallCamera();
  return o;
}

class SimLogTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SimLogTest, LogReadsBackWithCountsTimesAndBoardPointsOnTheBoard) {
  testing::TempDir dir;
  SessionOptions o = SmallSession(GetParam(), "static");
  SimOutputs out;
  out.log_path = dir.file("s.lcmlog");
  out.truth_path = dir.file("truth.json");
  SimSummary summary;
  std::string error;
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  ASSERT_EQ(summary.frames.size(), 5u);

  std::string text;
  ASSERT_TRUE(ReadWholeFile(out.truth_path, &text, &error)) << error;
  const auto truth = nlohmann::json::parse(text);
  const Received r = ReadBack(out.log_path);
  auto times = EventTimes(out.log_path);
  const auto& camera_event_utime = times[std::string(channels::kCamera.name)];
  const auto& lidar_event_utime = times[std::string(channels::kLidar.name)];
  ASSERT_EQ(camera_event_utime.size(), 5u);
  ASSERT_EQ(lidar_event_utime.size(), 5u);

  ASSERT_EQ(r.cameras.size(), 5u);
  ASSERT_EQ(r.lidars.size(), 5u);
  EXPECT_EQ(r.infos.size(), 2u);  // camera + LiDAR identity, once per second
  EXPECT_EQ(r.infos[1].serial_number, o.lidar_serial);

  int board_points_checked = 0;
  for (int k = 0; k < 5; ++k) {
    const auto& ft = truth["frames"][k];
    const auto& cam = r.cameras[k];
    const auto& lid = r.lidars[k];
    // Timestamps: the image at mid-exposure every 100 ms; the sweep logged when it completes.
    EXPECT_EQ(cam.utime, o.start_utime + 100000 * k);
    EXPECT_EQ(cam.utime, ft["camera_utime"].get<int64_t>());
    EXPECT_EQ(camera_event_utime[k], cam.utime);
    EXPECT_EQ(lid.utime, ft["lidar_utime"].get<int64_t>());
    EXPECT_EQ(lidar_event_utime[k], lid.utime + 100000);
    EXPECT_LT(lid.utime, cam.utime);
    EXPECT_EQ(cam.width, 960);
    EXPECT_EQ(cam.height, 480);
    EXPECT_EQ(cam.size, 960 * 480);
    EXPECT_EQ(static_cast<int>(cam.data.size()), cam.size);
    EXPECT_EQ(lid.num_points, ft["num_lidar_points"].get<int>());
    EXPECT_GT(lid.num_points, 10000);
    EXPECT_EQ(lid.lidar_id, o.lidar_id);

    // Static vehicle: every board point, mapped into the board frame with the true pose, lies on
    // the board plane within the range noise (4 sigma along the beam, plus quantization) and
    // inside the board's outline.
    for (const auto& bt : ft["boards"]) {
      const Pose T_board_lidar = PoseFromJson(bt["T_lidar_board"]).inverse();
      for (int idx : bt["lidar_point_indices"]) {
        const Eigen::Vector3d p_lidar(lid.x[idx], lid.y[idx], lid.z[idx]);
        const Eigen::Vector3d p_board = T_board_lidar * p_lidar;
        EXPECT_LT(std::abs(p_board.z()), 4 * 0.02 + 0.01) << "frame " << k << " point " << idx;
        EXPECT_LT(std::abs(p_board.x()), 0.3 + 0.1);
        EXPECT_LT(std::abs(p_board.y()), 0.3 + 0.1);
        ++board_points_checked;
      }
    }
  }
  // At 10 m the three 0.6 m boards carry tens to hundreds of points each per frame.
  EXPECT_GT(board_points_checked, 5 * 3 * 20);
}

INSTANTIATE_TEST_SUITE_P(Lidars, SimLogTest, ::testing::Values("ot128", "m1", "falcon"));

TEST(SimSessionTest, SameSeedSameBytesOtherSeedOtherBytes) {
  testing::TempDir dir;
  std::string error, a, b, c;
  SimSummary summary;
  SessionOptions o = SmallSession("m1", "drive");
  SimOutputs out;
  out.log_path = dir.file("a.lcmlog");
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  out.log_path = dir.file("b.lcmlog");
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  o.seed = 8;
  out.log_path = dir.file("c.lcmlog");
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  ASSERT_TRUE(ReadWholeFile(dir.file("a.lcmlog"), &a, &error));
  ASSERT_TRUE(ReadWholeFile(dir.file("b.lcmlog"), &b, &error));
  ASSERT_TRUE(ReadWholeFile(dir.file("c.lcmlog"), &c, &error));
  EXPECT_GT(a.size(), 1000000u);
  EXPECT_TRUE(a == b) << "same seed must give the same log, byte for byte";
  EXPECT_FALSE(a == c) << "another seed must give another log";
}

TEST(SimSessionTest, JpegFramesDecodeToTheRawImage) {
  testing::TempDir dir;
  std::string error;
  SimSummary summary;
  SessionOptions o = SmallSession("m1", "static");
  o.trajectory.duration_s = 0.1;
  SimOutputs out;
  out.log_path = dir.file("raw.lcmlog");
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  o.image_encoding = "jpeg";
  out.log_path = dir.file("jpeg.lcmlog");
  ASSERT_TRUE(RunSimulation(o, out, &summary, nullptr, &error)) << error;
  const Received raw = ReadBack(dir.file("raw.lcmlog"));
  const Received jpeg = ReadBack(dir.file("jpeg.lcmlog"));
  ASSERT_EQ(raw.cameras.size(), 1u);
  ASSERT_EQ(jpeg.cameras.size(), 1u);
  const auto& j = jpeg.cameras[0];
  EXPECT_EQ(j.encoding, int8_t{calibd::camera_frame_t::ENCODING_JPEG});
  EXPECT_LT(j.size, raw.cameras[0].size / 3);
  const cv::Mat decoded = cv::imdecode(j.data, cv::IMREAD_GRAYSCALE);
  ASSERT_EQ(decoded.cols, 960);
  ASSERT_EQ(decoded.rows, 480);
  const cv::Mat raw_img(480, 960, CV_8UC1, const_cast<uint8_t*>(raw.cameras[0].data.data()));
  EXPECT_LT(cv::norm(decoded, raw_img, cv::NORM_L1) / (960.0 * 480.0), 3.0);
}

}  // namespace
}  // namespace calibd::sim
