// lidar.model generic end to end: a drive simulated with the OT128, M1 or Falcon pattern is
// detected and calibrated twice from the same frames, once with the built-in model and once as a
// generic sensor whose range image comes from the resolution estimated on the first three sweeps
// (lidar_resolution.hpp). The generic result must be as good as the named one, within a stated
// margin.

#include <gtest/gtest.h>

#include <cstdio>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "session.hpp"
#include "short_session.hpp"

namespace calibd {
namespace {

struct Errors {
  double rotation_deg = 1e9, translation_m = 1e9;
};

class GenericLidarTest : public ::testing::TestWithParam<std::string> {};

// Both calibrations must be updated; generic within 0.05 deg and 5 mm of the named model's
// error, and within the engine tests' bounds against the truth (0.1 deg, 15 mm).
TEST_P(GenericLidarTest, DriveCalibratedAsGenericMatchesTheNamedModel) {
  sim::SessionOptions o;
  o.lidar_model = GetParam();
  o.prior_rot_deg = 3.0;
  o.prior_trans_m = 0.03;
  // 6-20 m: 32 pairs of boards out to 30 m measure their distances to about the translation's
  // tolerance only (falcon: +-1.5 cm), at the poor_observability gate.
  o.trajectory.max_distance_m = 20.0;
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  const CalibConfig config = s.UserConfig();
  const int count = 32, stride = 6;  // 32 pairs over the 20 s drive

  // The frames, simulated once.
  std::vector<sim::LidarScan> scans(count);
  std::vector<CameraDetections> camera(count);
  std::vector<FrameTimes> times(count);
  CameraDetector camera_detector(CameraDetectorConfig{}, o.camera, config.boards);
  ASSERT_TRUE(camera_detector.ok()) << camera_detector.error();
  cv::Mat image;
  sim::FrameTruth truth;
  for (int k = 0; k < count; ++k) {
    s.SimulateFrame(stride * k, &image, &scans[k], &truth);
    camera_detector.Detect(
        ImageView{image.data, image.cols, image.rows, static_cast<int>(image.step[0])}, &camera[k]);
    times[k] = FrameTimes{truth.camera_utime, truth.lidar_utime};
  }
  auto view = [&](int k) {
    // A generic sensor reports no ring: the named model keeps its rings.
    return PointCloudView{
        scans[k].x.data(), scans[k].y.data(),
        scans[k].z.data(), s.lidar_model().has_rings ? scans[k].ring.data() : nullptr,
        scans[k].size(),   scans[k].time_offset_us.data()};
  };

  // The generic model from the first three sweeps, as calibd-calibrate does.
  std::vector<PointCloudView> first;
  for (int k = 0; k < 3; ++k) {
    first.push_back(view(k));
    first.back().ring = nullptr;
  }
  const LidarResolutionEstimate estimate = EstimateLidarResolution(first.data(), first.size());
  ASSERT_TRUE(estimate.ok) << estimate.error;
  LidarModel generic;
  ASSERT_TRUE(MakeGenericLidarModel(GenericLidarConfig{}, &estimate, &generic, &error)) << error;
  std::printf("%s\n", DescribeGenericLidar(generic, &estimate).c_str());

  auto calibrate = [&](const LidarModel& model, bool rings, int* lidar_boards) {
    LidarDetector lidar(LidarDetectorConfig{}, model, config.boards);
    EXPECT_TRUE(lidar.ok()) << lidar.error();
    SessionObservations obs;
    obs.Reserve(count, static_cast<int>(config.boards.size()) + 4, 4096);
    LidarDetections ld;
    for (int k = 0; k < count; ++k) {
      PointCloudView cloud = view(k);
      if (!rings) cloud.ring = nullptr;
      lidar.Detect(cloud, &ld);
      EXPECT_TRUE(obs.AddFrame(camera[k], ld, config.boards, times[k]));
    }
    *lidar_boards = static_cast<int>(obs.lidar.size());
    const RangeImage projection = SessionProjection(model);
    const CalibrationOutcome out =
        Calibrate(config, obs, projection, testing::ShortSessionEngine());
    EXPECT_EQ(out.verdict, CalibrationOutcome::Verdict::kUpdated)
        << model.name << ": " << out.reason << ": " << out.detail;
    Errors e;
    e.rotation_deg =
        RotationAngle(out.T_camera_lidar.linear(), s.T_camera_lidar().linear()) / kDeg2Rad;
    e.translation_m = (out.T_camera_lidar.translation() - s.T_camera_lidar().translation()).norm();
    return e;
  };
  int named_boards = 0, generic_boards = 0;
  const Errors named = calibrate(s.lidar_model(), true, &named_boards);
  const Errors gen = calibrate(generic, false, &generic_boards);
  std::printf("%s: named %.4f deg %.4f m (%d LiDAR boards), generic %.4f deg %.4f m (%d)\n",
              GetParam().c_str(), named.rotation_deg, named.translation_m, named_boards,
              gen.rotation_deg, gen.translation_m, generic_boards);
  EXPECT_GT(generic_boards, 0.9 * named_boards);
  EXPECT_LT(gen.rotation_deg, named.rotation_deg + 0.05);
  EXPECT_LT(gen.translation_m, named.translation_m + 0.005);
  EXPECT_LT(gen.rotation_deg, 0.1);
  EXPECT_LT(gen.translation_m, 0.015);
}

INSTANTIATE_TEST_SUITE_P(Models, GenericLidarTest, ::testing::Values("ot128", "m1", "falcon"),
                         [](const ::testing::TestParamInfo<std::string>& p) { return p.param; });

}  // namespace
}  // namespace calibd
