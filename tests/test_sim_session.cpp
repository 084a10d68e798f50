// Session-level properties of the simulator: the trajectory, the extrinsic truth vs the prior in
// the user config, board visibility, and the command line's handling of bad options.

#include <gtest/gtest.h>

#include <sys/wait.h>
#include <cstdio>
#include <cstdlib>

#include "calibd/drivers/config_file.hpp"
#include "run_command.hpp"
#include "session.hpp"
#include "small_camera.hpp"
#include "temp_dir.hpp"

namespace calibd::sim {
namespace {

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

// `poses` still poses of one 0.9 m board (0.702 m tag) on a tripod, no other clutter, seen by a
// dense LiDAR (ot128) without range noise or dropouts.
SessionOptions OneBoardStills(int poses) {
  SessionOptions o = SmallCamera(SessionOptions{});
  o.lidar_model = "ot128";
  o.trajectory.mode = "stills";
  o.trajectory.rate_hz = 0.5;
  o.trajectory.duration_s = poses / o.trajectory.rate_hz;
  o.workshop.num_boards = 1;
  o.workshop.board_width_m = o.workshop.board_height_m = 0.9;
  o.workshop.tag_size_m = 0.702;
  o.stills.clutter = false;
  o.lidar_noise = LidarNoise{};
  o.lidar_noise.range_sigma_m = 0.0;
  o.lidar_noise.dropout_probability = 0.0;
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

// The faults calibd-bench verdicts injects: a range bias moves every return along its beam by the
// bias; a late camera sees the scene (and is stamped) later, the LiDAR's sweep keeps its time.
TEST(SessionTest, RangeBiasAndCameraDelayAreWhatTheTruthSays) {
  SessionOptions o = SmallCamera(SessionOptions{});
  o.lidar_model = "vlp16";
  o.lidar_noise = LidarNoise{};
  o.lidar_noise.range_sigma_m = 0.0;
  o.lidar_noise.angular_jitter_deg = 0.0;
  o.lidar_noise.dropout_probability = 0.0;
  o.lidar_noise.mixed_point_probability = 0.0;
  SessionOptions faulty = o;
  faulty.lidar_noise.range_bias_m = 0.04;
  faulty.camera_delay_us = 30000;
  SessionSimulator clean_sim, faulty_sim;
  std::string error;
  ASSERT_TRUE(clean_sim.Init(o, &error)) << error;
  ASSERT_TRUE(faulty_sim.Init(faulty, &error)) << error;
  LidarScan clean_scan, faulty_scan;
  FrameTruth clean, late;
  clean_sim.SimulateFrame(20, nullptr, &clean_scan, &clean);
  faulty_sim.SimulateFrame(20, nullptr, &faulty_scan, &late);
  EXPECT_EQ(late.lidar_utime, clean.lidar_utime);
  EXPECT_EQ(late.camera_utime, clean.camera_utime + 30000);
  // Driving: the camera's view of a board 30 ms later differs by the vehicle's motion.
  const double moved =
      (late.boards[0].T_camera_board.translation() - clean.boards[0].T_camera_board.translation())
          .norm();
  EXPECT_GT(moved, 0.01);
  ASSERT_EQ(faulty_scan.size(), clean_scan.size());
  ASSERT_GT(clean_scan.size(), 1000u);
  for (size_t i = 0; i < clean_scan.size(); i += 97) {
    const Eigen::Vector3d a(clean_scan.x[i], clean_scan.y[i], clean_scan.z[i]);
    const Eigen::Vector3d b(faulty_scan.x[i], faulty_scan.y[i], faulty_scan.z[i]);
    EXPECT_NEAR(b.norm() - a.norm(), 0.04, 2e-3) << "point " << i;
  }
}

// The occlusion fault of calibd-bench verdicts: someone in front of the board hides about the
// requested share of its width from the LiDAR. Still poses of one board on a tripod (no other
// clutter), dense LiDAR, no noise: the board's points with 30 % hidden against the same poses
// with nobody in front.
TEST(SessionTest, AnOccluderHidesAboutItsShareOfTheBoard) {
  const SessionOptions o = OneBoardStills(8);
  SessionOptions hidden = o;
  hidden.stills.occluded_share = 0.3;
  SessionSimulator clean_sim, hidden_sim;
  std::string error;
  ASSERT_TRUE(clean_sim.Init(o, &error)) << error;
  ASSERT_TRUE(hidden_sim.Init(hidden, &error)) << error;
  LidarScan scan;
  FrameTruth clean, occluded;
  size_t clean_points = 0, occluded_points = 0;
  for (int pose = 0; pose < 8; ++pose) {
    clean_sim.SimulateFrame(pose, nullptr, &scan, &clean);
    hidden_sim.SimulateFrame(pose, nullptr, &scan, &occluded);
    ASSERT_EQ(clean.boards.size(), 1u);
    ASSERT_EQ(occluded.boards.size(), 1u);
    EXPECT_TRUE(clean.boards[0].T_lidar_board.isApprox(occluded.boards[0].T_lidar_board))
        << "pose " << pose << ": the same board pose with and without the occluder";
    clean_points += clean.boards[0].lidar_point_indices.size();
    occluded_points += occluded.boards[0].lidar_point_indices.size();
  }
  ASSERT_GT(clean_points, 1000u);
  const double kept = static_cast<double>(occluded_points) / static_cast<double>(clean_points);
  std::printf("30 %% hidden: %.3f of the board's points kept\n", kept);
  EXPECT_GT(kept, 0.55);
  EXPECT_LT(kept, 0.85);
}

TEST(SessionTest, ABowedBoardBulgesByItsBowAtItsCentreLine) {
  SessionOptions o = OneBoardStills(4);
  o.workshop.board_bows_m = {0.02};
  SessionSimulator sim;
  std::string error;
  ASSERT_TRUE(sim.Init(o, &error)) << error;
  LidarScan scan;
  FrameTruth truth;
  // Heights of the board's points over its flat face (board frame z_B, the sensors' side)
  // near its centre line and near its left and right edges.
  double centre = 0.0, edges = 0.0;
  int n_centre = 0, n_edges = 0;
  for (int pose = 0; pose < 4; ++pose) {
    sim.SimulateFrame(pose, nullptr, &scan, &truth);
    ASSERT_EQ(truth.boards.size(), 1u);
    const Pose T_board_lidar = truth.boards[0].T_lidar_board.inverse();
    for (const int i : truth.boards[0].lidar_point_indices) {
      const Eigen::Vector3d p = T_board_lidar * Eigen::Vector3d(scan.x[i], scan.y[i], scan.z[i]);
      if (std::abs(p.x()) < 0.1) {
        centre += p.z();
        ++n_centre;
      } else if (std::abs(p.x()) > 0.38) {
        edges += p.z();
        ++n_edges;
      }
    }
  }
  ASSERT_GT(n_centre, 50);
  ASSERT_GT(n_edges, 50);
  centre /= n_centre;
  edges /= n_edges;
  std::printf("bow 20 mm: %.1f mm out at the centre line, %.1f mm near the edges\n", centre * 1e3,
              edges * 1e3);
  EXPECT_NEAR(centre, 0.0197, 0.002);  // 20 mm (1 - (x / 0.45)^2) averaged over |x| < 0.1
  EXPECT_NEAR(edges, 0.0030, 0.002);   // over 0.38 < |x| < 0.45
}

// Boards still carried at 0.5 m/s while a pose's four frames are taken, the camera exposing
// 40 ms after the trigger: each sensor sees a board where it is at its own time, 2 cm apart,
// and the board moves 5 cm from one frame to the next; standing boards are where they were.
TEST(SessionTest, CarriedBoardsAreSeenWhereTheyAreAtEachSensorsTime) {
  SessionOptions o = OneBoardStills(2);
  o.workshop.num_boards = 2;
  o.stills.frames_per_pose = 4;
  o.stills.board_speed_mps = 0.5;
  o.camera_delay_us = 40000;
  SessionSimulator sim;
  std::string error;
  ASSERT_TRUE(sim.Init(o, &error)) << error;
  LidarScan scan;
  FrameTruth truth;
  std::vector<Eigen::Vector3d> previous;
  for (int k = 0; k < 8; ++k) {
    sim.SimulateFrame(k, nullptr, &scan, &truth);
    ASSERT_EQ(truth.boards.size(), 2u);
    std::vector<Eigen::Vector3d> at_camera;
    for (const BoardTruth& b : truth.boards) {
      const Eigen::Vector3d camera = b.T_camera_board.translation();
      const Eigen::Vector3d lidar = (sim.T_camera_lidar() * b.T_lidar_board).translation();
      EXPECT_NEAR((camera - lidar).norm(), 0.5 * 0.04, 1e-9) << "frame " << k;
      at_camera.push_back(camera);
    }
    if (k % 4 != 0) {
      for (size_t b = 0; b < 2; ++b)
        EXPECT_NEAR((at_camera[b] - previous[b]).norm(), 0.5 * 0.1, 1e-6) << "frame " << k;
    }
    previous = at_camera;
  }
  o.stills.board_speed_mps = 0.0;
  ASSERT_TRUE(sim.Init(o, &error)) << error;
  sim.SimulateFrame(1, nullptr, &scan, &truth);
  for (const BoardTruth& b : truth.boards)
    EXPECT_TRUE(b.T_camera_board.isApprox(sim.T_camera_lidar() * b.T_lidar_board, 1e-12));
}

// A rolling shutter read out over 30 ms while driving: its upper rows are nearer what a global
// shutter sees at the capture time, its bottom rows what one sees 30 ms later (the same noise
// and exposure, drawn from the frame's seed); the frame is stamped at its first row.
TEST(SessionTest, ARollingShuttersRowsSeeTheSceneAtTheirOwnTime) {
  const SessionOptions global = SmallCamera(SessionOptions{});
  SessionOptions rolling = global, late = global;
  rolling.camera_readout_us = 30000;
  late.camera_delay_us = 30000;
  cv::Mat images[3];
  FrameTruth truths[3];
  int i = 0;
  for (const SessionOptions& o : {global, rolling, late}) {
    SessionSimulator sim;
    std::string error;
    ASSERT_TRUE(sim.Init(o, &error)) << error;
    LidarScan scan;
    sim.SimulateFrame(20, &images[i], &scan, &truths[i]);
    ++i;
  }
  EXPECT_EQ(truths[1].camera_utime, truths[0].camera_utime);
  const int rows = images[0].rows, band = rows / 20;
  auto mean_difference = [&](const cv::Mat& a, const cv::Mat& b, int r0) {
    return cv::norm(a.rowRange(r0, r0 + band), b.rowRange(r0, r0 + band), cv::NORM_L1) /
           static_cast<double>(band * a.cols);
  };
  // The top band where the scene moved at all (the sky above the horizon does not).
  int top = 0;
  while (top + band < rows / 2 && mean_difference(images[0], images[2], top) < 0.5) top += band;
  ASSERT_LT(top + band, rows / 2) << "nothing moved in the upper half";
  const double top_early = mean_difference(images[1], images[0], top);
  const double top_late = mean_difference(images[1], images[2], top);
  const double bottom_early = mean_difference(images[1], images[0], rows - band);
  const double bottom_late = mean_difference(images[1], images[2], rows - band);
  std::printf("grey levels apart, rows %d+: %.2f early / %.2f late; bottom: %.2f / %.2f\n", top,
              top_early, top_late, bottom_early, bottom_late);
  EXPECT_LT(top_early, top_late);  // a third of the readout down: nearer the capture time
  EXPECT_LT(bottom_late, 0.5 * bottom_early);
  std::string error;
  SessionOptions bad = global;
  bad.camera_readout_us = -1;
  EXPECT_FALSE(bad.IsValid(&error));
  EXPECT_NE(error.find("--camera-readout-us"), std::string::npos);
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
