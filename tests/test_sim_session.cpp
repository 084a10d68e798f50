// Session-level properties of the simulator: the trajectory, the extrinsic truth vs the prior in
// the user config, board visibility, and the command line's handling of bad options.

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <cstdlib>

#include "calibd/drivers/config_file.hpp"
#include "run_command.hpp"
#include "session.hpp"
#include "small_camera.hpp"
#include "temp_dir.hpp"

namespace calibd::sim {
namespace {

constexpr double kRad2Deg = 180.0 / M_PI;

TEST(TrajectoryTest, DriveGoesFromNearToFarAndBack) {
  TrajectoryOptions t;
  const double lidar_x = 1.2;
  auto distance = [&](double s) {
    return -(VehiclePoseAt(t, lidar_x, s).translation().x() + lidar_x);
  };
  EXPECT_NEAR(distance(0.0), 6.0, 1e-9);
  EXPECT_NEAR(distance(10.0), 30.0, 1e-9);
  EXPECT_NEAR(distance(20.0), 6.0, 1e-9);
  EXPECT_EQ(t.num_frames(), 200);
  t.mode = "close";
  for (double s = 0; s <= 20; s += 0.5) EXPECT_LE(distance(s), 8.5 + 1e-9);
  t.mode = "far";
  for (double s = 0; s <= 20; s += 0.5) EXPECT_GE(distance(s), 25.0 - 1e-9);
  t.mode = "static";
  EXPECT_NEAR(distance(3.0), 10.0, 1e-9);
  EXPECT_TRUE(VehiclePoseAt(t, lidar_x, 3.0).isApprox(VehiclePoseAt(t, lidar_x, 13.0)));
}

SessionOptions SmallCamera(SessionOptions o) {
  o.camera = testing::SmallCamera();
  return o;
}

TEST(SessionTest, PriorDiffersFromTruthByTheRequestedErrorAndConfigHoldsOnlyThePrior) {
  SessionOptions o = SmallCamera(SessionOptions{});
  o.prior_rot_deg = 5.0;
  o.prior_trans_m = 0.05;
  SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  EXPECT_NEAR(
      RotationAngle(s.T_camera_lidar().linear(), s.prior_T_camera_lidar().linear()) * kRad2Deg, 5.0,
      1e-9);
  EXPECT_NEAR((s.T_camera_lidar().translation() - s.prior_T_camera_lidar().translation()).norm(),
              0.05, 0.05 * 0.2 + 1e-9);  // rotation of the offset moves it slightly
  const CalibConfig c = s.UserConfig();
  EXPECT_TRUE(c.prior_T_camera_lidar.isApprox(s.prior_T_camera_lidar()));
  EXPECT_FALSE(c.prior_T_camera_lidar.isApprox(s.T_camera_lidar(), 1e-3));
  ASSERT_TRUE(c.IsValid(&error)) << error;
  EXPECT_EQ(c.boards.size(), 3u);
  // A forward camera and a forward LiDAR: the LiDAR's x axis is the camera's z axis (about).
  const Eigen::Vector3d lidar_x_in_camera = s.T_camera_lidar().linear().col(0);
  EXPECT_GT(lidar_x_in_camera.z(), 0.99);
  // The truth is the composition of the mounts.
  EXPECT_TRUE(s.T_camera_lidar().isApprox(s.T_vehicle_camera().inverse() * s.T_vehicle_lidar()));
}

TEST(SessionTest, BoardsVisibleToBothSensorsAcrossTheDrive) {
  SessionOptions o = SmallCamera(SessionOptions{});
  o.lidar_model = "m1";
  SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  LidarScan scan;
  FrameTruth truth;
  cv::Mat image;
  for (int k : {0, 50, 100}) {  // 6 m, 18 m and 30 m
    s.SimulateFrame(k, &image, &scan, &truth);
    ASSERT_EQ(truth.boards.size(), 3u);
    for (const auto& b : truth.boards) {
      EXPECT_TRUE(b.tag_in_image) << "frame " << k << " board " << b.board_id;
      EXPECT_GE(b.lidar_point_indices.size(), 10u) << "frame " << k << " board " << b.board_id;
    }
  }
}

TEST(SessionTest, BadOptionsAreRejectedWithTheirName) {
  std::string error;
  SessionOptions o;
  o.lidar_model = "velodyne";
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("velodyne"), std::string::npos);
  o = SessionOptions{};
  o.prior_rot_deg = 12.0;
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("--prior-rot-deg"), std::string::npos);
  o = SessionOptions{};
  o.workshop.tag_ids = {1, 1, 2};
  EXPECT_FALSE(o.IsValid(&error));
  EXPECT_NE(error.find("--tag-ids"), std::string::npos);
}

int RunSim(const std::string& args) {
  return testing::RunCommand(std::string(CALIBD_SIM_EXE) + " " + args + " >/dev/null 2>&1");
}

TEST(SimCliTest, HelpSucceedsAndBadOptionsExitWithTwo) {
  testing::TempDir dir;
  const std::string out = " --out " + dir.file("x.lcmlog");
  EXPECT_EQ(RunSim("--help"), 0);
  EXPECT_EQ(RunSim("--bogus" + out), 2);
  EXPECT_EQ(RunSim("--lidar velodyne" + out), 2);
  EXPECT_EQ(RunSim("--seed abc" + out), 2);
  EXPECT_EQ(RunSim("--distance 30" + out), 2);
  EXPECT_EQ(RunSim("--prior-rot-deg 11" + out), 2);
  EXPECT_EQ(RunSim("--boards 2 --tag-ids 1,2,3" + out), 2);
  EXPECT_EQ(RunSim("--seed 3"), 2);  // no --out
  EXPECT_EQ(RunSim("--out"), 2);     // missing value
  EXPECT_EQ(RunSim("--out /nonexistent-dir/x.lcmlog --frames 1"), 1);
}

}  // namespace
}  // namespace calibd::sim
