#include "lidar_sim.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <iostream>

#include "calibd/core/common/stopwatch.hpp"

namespace calibd::sim {
namespace {

constexpr double kBoardW = 1.0, kBoardH = 0.8, kBoardThickness = 0.02;

LidarNoise NoNoise() {
  LidarNoise n;
  n.range_sigma_m = 0.0;
  n.angular_jitter_deg = 0.0;
  n.dropout_probability = 0.0;
  n.beam_divergence_mrad = 0.0;
  n.mixed_point_probability = 0.0;
  return n;
}

Pose At(double x, double y, double z, double yaw = 0.0) {
  return PoseFromXyzRpy(Eigen::Vector3d(x, y, z), Eigen::Vector3d(0.0, 0.0, yaw));
}

void AddGround(Scene* scene) {
  Primitive g;
  g.shape = Primitive::Shape::kPlaneZ0;
  g.kind = SurfaceKind::kGround;
  g.albedo = 0.3f;
  scene->Add(g);
}

// A wall whose face towards the origin is the plane x = face_x, |y| <= half_width.
void AddWall(Scene* scene, double face_x, double half_width = 20.0) {
  Primitive w;
  w.shape = Primitive::Shape::kBox;
  w.kind = SurfaceKind::kWall;
  w.T_world_local = At(face_x + 0.5, 0.0, 3.0);
  w.half_extents = Eigen::Vector3d(0.5, half_width, 3.0);
  w.albedo = 0.6f;
  scene->Add(w);
}

// A board facing the origin, its centre at (x, 0, z): board z axis = -x_W, x_B = -y_W, y_B = z_W.
Pose BoardFacingOrigin(double x, double z) {
  Pose T = Pose::Identity();
  T.linear().col(0) = -Eigen::Vector3d::UnitY();
  T.linear().col(1) = Eigen::Vector3d::UnitZ();
  T.linear().col(2) = -Eigen::Vector3d::UnitX();
  T.translation() = Eigen::Vector3d(x, 0.0, z);
  return T;
}

void AddBoard(Scene* scene, const Pose& T_world_board) {
  Primitive b;
  b.shape = Primitive::Shape::kBox;
  b.kind = SurfaceKind::kBoard;
  b.T_world_local = T_world_board;
  b.half_extents = Eigen::Vector3d(0.5 * kBoardW, 0.5 * kBoardH, 0.5 * kBoardThickness);
  b.albedo = 0.9f;
  b.board_index = static_cast<int>(scene->boards.size());
  PlacedBoard placed;
  placed.T_world_board = T_world_board;
  placed.primitive_index = scene->Add(b);
  scene->boards.push_back(placed);
}

LidarScan ScanOnce(const Scene& scene, LidarKind kind, const LidarNoise& noise, uint64_t seed,
                   const Pose& start, const Pose& end, int frame = 0) {
  LidarSimulator sim(MakeLidarModel(kind), noise);
  LidarScan scan;
  sim.Scan(scene, start, end, frame, seed, &scan);
  return scan;
}

Eigen::Vector3d PointAt(const LidarScan& s, size_t i) {
  return Eigen::Vector3d(s.x[i], s.y[i], s.z[i]);
}

TEST(LidarSimTest, GroundPointsLieOnThePlaneWithinNoise) {
  Scene scene;
  AddGround(&scene);
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.8);
  LidarNoise noise = NoNoise();
  noise.range_sigma_m = 0.02;
  const LidarScan noisy = ScanOnce(scene, LidarKind::kOt128, noise, 1, T, T);
  ASSERT_GT(noisy.size(), 50000u);
  // Gaussian: 6e-5 of the points fall beyond 4 sigma, none beyond 6.
  size_t beyond_4_sigma = 0;
  for (size_t i = 0; i < noisy.size(); ++i) {
    const double dz = std::abs((T * PointAt(noisy, i)).z());
    beyond_4_sigma += dz > 4.0 * 0.02 + 0.004;
    ASSERT_LT(dz, 6.0 * 0.02 + 0.004) << i;
  }
  EXPECT_LE(beyond_4_sigma, noisy.size() / 2000);

  const LidarScan exact = ScanOnce(scene, LidarKind::kOt128, NoNoise(), 1, T, T);
  ASSERT_GT(exact.size(), 50000u);
  for (size_t i = 0; i < exact.size(); ++i) {
    // Only the 4 mm range quantization remains, projected on the plane normal.
    const Eigen::Vector3d p = PointAt(exact, i);
    ASSERT_LE(std::abs((T * p).z()), 0.5 * 0.004 * std::abs(p.z()) / p.norm() + 1e-4) << i;
  }
}

TEST(LidarSimTest, BoardPointsLieInsideTheBoardRectangle) {
  Scene scene;
  AddGround(&scene);
  AddWall(&scene, 12.0);
  AddBoard(&scene, BoardFacingOrigin(5.0, 1.5));
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.5);
  for (const bool noisy : {false, true}) {
    SCOPED_TRACE(noisy ? "default noise" : "no noise");
    const LidarNoise noise = noisy ? LidarNoise() : NoNoise();
    const LidarScan scan = ScanOnce(scene, LidarKind::kOt128, noise, 7, T, T);
    const Pose T_board_lidar = scene.boards[0].T_world_board.inverse() * T;
    int on_board = 0, beyond_4_sigma = 0;
    for (size_t i = 0; i < scan.size(); ++i) {
      if (scan.board[i] != 0) continue;
      ++on_board;
      const Eigen::Vector3d p_board = T_board_lidar * PointAt(scan, i);
      // Margin with noise: half the 2 mrad footprint at ~5.2 m (edge beams take the nearest
      // surface, 5.2 mm), 4 sigma of jitter (3.6 mm) and 4 sigma of range noise along rays up to
      // ~6 deg off the board normal (8 mm).
      const double margin = noisy ? 0.02 : 1e-3;
      EXPECT_LE(std::abs(p_board.x()), 0.5 * kBoardW + margin);
      EXPECT_LE(std::abs(p_board.y()), 0.5 * kBoardH + margin);
      // Depth off the printed face: range noise (4 sigma for all but a few) and quantization.
      const double depth = std::abs(p_board.z() - 0.5 * kBoardThickness);
      if (noisy) {
        beyond_4_sigma += depth > 4.0 * 0.02 + 0.004;
        EXPECT_LE(depth, 6.0 * 0.02 + 0.004);
      } else {
        EXPECT_LE(depth, 0.5 * 0.004 + 1e-4);
      }
    }
    // 1 m x 0.8 m at 5 m: ~57 columns x ~73 rows of the 0.125 deg band.
    EXPECT_GT(on_board, 2000);
    EXPECT_LE(beyond_4_sigma, 3);
  }
}

TEST(LidarSimTest, IntensityFollowsAlbedoAndIncidence) {
  Scene scene;
  AddBoard(&scene, BoardFacingOrigin(5.0, 0.0));
  scene.Finalize();
  const LidarScan scan =
      ScanOnce(scene, LidarKind::kOt128, NoNoise(), 3, Pose::Identity(), Pose::Identity());
  ASSERT_GT(scan.size(), 100u);
  for (size_t i = 0; i < scan.size(); ++i) {
    const Eigen::Vector3d p = PointAt(scan, i);
    const double cos_incidence = p.x() / p.norm();  // board normal is -x
    EXPECT_NEAR(scan.intensity[i], 255.0 * 0.9 * cos_incidence, 0.5);
  }
}

TEST(LidarSimTest, SameSeedSameScanOtherSeedOtherScan) {
  Scene scene;
  AddGround(&scene);
  AddWall(&scene, 10.0);
  AddBoard(&scene, BoardFacingOrigin(4.0, 1.2));
  scene.Finalize();
  const Pose T0 = At(0.0, 0.0, 1.5), T1 = At(0.3, 0.1, 1.5, 0.05);
  for (LidarKind kind : {LidarKind::kOt128, LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarScan a = ScanOnce(scene, kind, LidarNoise(), 42, T0, T1);
    const LidarScan b = ScanOnce(scene, kind, LidarNoise(), 42, T0, T1);
    const LidarScan c = ScanOnce(scene, kind, LidarNoise(), 43, T0, T1);
    ASSERT_GT(a.size(), 1000u);
    EXPECT_EQ(a.x, b.x);
    EXPECT_EQ(a.y, b.y);
    EXPECT_EQ(a.z, b.z);
    EXPECT_EQ(a.intensity, b.intensity);
    EXPECT_EQ(a.board, b.board);
    EXPECT_EQ(a.time_offset_us, b.time_offset_us);
    EXPECT_NE(a.x, c.x);
  }
}

TEST(LidarSimTest, ReusedSimulatorIsDeterministicAcrossFrames) {
  Scene scene;
  AddGround(&scene);
  AddWall(&scene, 8.0);
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.5);
  LidarSimulator sim(MakeLidarModel(LidarKind::kM1), LidarNoise());
  LidarScan f0, f1, f0_again;
  sim.Scan(scene, T, T, 0, 5, &f0);
  sim.Scan(scene, T, T, 1, 5, &f1);
  sim.Scan(scene, T, T, 0, 5, &f0_again);
  EXPECT_EQ(f0.x, f0_again.x);
  EXPECT_EQ(f0.z, f0_again.z);
  EXPECT_NE(f0.z, f1.z);  // the MEMS raster moved between frames
}

TEST(LidarSimTest, DropoutRemovesTheConfiguredFraction) {
  Scene scene;
  AddGround(&scene);
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.8);
  LidarNoise noise = NoNoise();
  const double all = static_cast<double>(ScanOnce(scene, LidarKind::kOt128, noise, 9, T, T).size());
  noise.dropout_probability = 0.2;
  const double kept =
      static_cast<double>(ScanOnce(scene, LidarKind::kOt128, noise, 9, T, T).size());
  ASSERT_GT(all, 50000.0);
  // Binomial with n > 50k: sigma of the kept fraction < 0.002.
  EXPECT_NEAR(kept / all, 0.8, 0.01);
}

// Points between the board (5 m) and the wall behind it (15 m), with no ground in the scene.
int CountGhostPoints(const LidarScan& scan) {
  int ghosts = 0;
  for (size_t i = 0; i < scan.size(); ++i) {
    const double r = PointAt(scan, i).norm();
    if (r > 5.4 && r < 14.6) {
      ++ghosts;
      EXPECT_EQ(scan.board[i], -1);
    }
  }
  return ghosts;
}

TEST(LidarSimTest, MixedPointsAppearAtBoardEdgesOnlyWhenEnabled) {
  Scene scene;
  AddWall(&scene, 15.0);
  // Rolled by 10 deg so its edges cross the beam grid at every phase (an upright board's edges
  // could fall between footprints on every row).
  Pose T_world_board = BoardFacingOrigin(5.0, 1.5);
  T_world_board.linear() = T_world_board.linear() * RotationFromRpy(0.0, 0.0, 0.17);
  AddBoard(&scene, T_world_board);
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.5);  // the wall is behind every part of the board
  LidarNoise noise = NoNoise();
  noise.beam_divergence_mrad = 2.0;
  noise.mixed_point_probability = 0.5;
  const int with_mixing = CountGhostPoints(ScanOnce(scene, LidarKind::kOt128, noise, 11, T, T));
  // ~60 rows cross each side edge and ~57 columns the top and bottom edges; a 1 mrad footprint
  // radius straddles a side edge for ~57% of the rows (3.5 mrad column spacing), and half of
  // those report a mixed range: expect several tens.
  EXPECT_GT(with_mixing, 20);
  EXPECT_LT(with_mixing, 400);

  noise.mixed_point_probability = 0.0;
  EXPECT_EQ(CountGhostPoints(ScanOnce(scene, LidarKind::kOt128, noise, 11, T, T)), 0);
  EXPECT_EQ(CountGhostPoints(ScanOnce(scene, LidarKind::kOt128, NoNoise(), 11, T, T)), 0);

  // MEMS patterns get them too.
  noise.mixed_point_probability = 0.5;
  EXPECT_GT(CountGhostPoints(ScanOnce(scene, LidarKind::kM1, noise, 11, T, T)), 5);
  EXPECT_GT(CountGhostPoints(ScanOnce(scene, LidarKind::kFalcon, noise, 11, T, T)), 5);
}

// Exact pose at a firing time, as a consumer would de-skew: lerp + slerp.
Pose PoseAtTime(const Pose& a, const Pose& b, double s) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(a.rotation())
                   .slerp(s, Eigen::Quaterniond(b.rotation()))
                   .toRotationMatrix();
  T.translation() = (1.0 - s) * a.translation() + s * b.translation();
  return T;
}

TEST(LidarSimTest, PointsAreInTheLidarFrameAtTheirFiringTime) {
  Scene scene;
  AddGround(&scene);
  AddWall(&scene, 10.0);
  scene.Finalize();
  const Pose start = At(0.0, 0.0, 1.5, 0.0), end = At(1.0, 0.0, 1.5, 0.1);
  for (LidarKind kind : {LidarKind::kOt128, LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarModel model = MakeLidarModel(kind);
    SCOPED_TRACE(model.name);
    const LidarScan scan = ScanOnce(scene, kind, NoNoise(), 2, start, end);
    ASSERT_GT(scan.size(), 10000u);
    const double period_us = 1e6 / model.frame_rate_hz;
    int wall = 0, wall_off_with_start_pose = 0;
    for (size_t i = 0; i < scan.size(); ++i) {
      const Eigen::Vector3d p = PointAt(scan, i);
      const Eigen::Vector3d p_w = PoseAtTime(start, end, scan.time_offset_us[i] / period_us) * p;
      const double residual = std::min(std::abs(p_w.z()), std::abs(p_w.x() - 10.0));
      ASSERT_LT(residual, 0.01) << "point " << i << " at " << p_w.transpose();
      if (std::abs(p_w.x() - 10.0) < 0.01 && p_w.z() > 0.05) {
        ++wall;
        if (std::abs((start * p).x() - 10.0) > 0.05) ++wall_off_with_start_pose;
      }
    }
    ASSERT_GT(wall, 1000);
    // Without per-point poses most wall points are off by up to the 1 m travelled.
    EXPECT_GT(wall_off_with_start_pose, wall / 2);
  }
}

TEST(LidarSimTest, MemsModelsReportNoRing) {
  Scene scene;
  AddGround(&scene);
  AddWall(&scene, 8.0);
  scene.Finalize();
  const Pose T = At(0.0, 0.0, 1.5);
  for (LidarKind kind : {LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarScan scan = ScanOnce(scene, kind, LidarNoise(), 4, T, T);
    ASSERT_GT(scan.size(), 10000u);
    for (int16_t r : scan.ring) ASSERT_EQ(r, -1);
  }
  const LidarScan ot = ScanOnce(scene, LidarKind::kOt128, LidarNoise(), 4, T, T);
  for (int16_t r : ot.ring) {
    ASSERT_GE(r, 0);
    ASSERT_LT(r, 128);
  }
}

TEST(LidarSimTest, EmptySceneGivesEmptyScan) {
  Scene scene;
  scene.Finalize();
  for (LidarKind kind : {LidarKind::kOt128, LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarScan scan =
        ScanOnce(scene, kind, LidarNoise(), 1, Pose::Identity(), At(1.0, 0.0, 0.0));
    EXPECT_EQ(scan.size(), 0u);
    EXPECT_TRUE(scan.board.empty());
  }
}

// A workshop-like scene of ~30 primitives: ground, 4 walls, 3 boards on stands, clutter.
Scene WorkshopScene() {
  Scene scene;
  AddGround(&scene);
  for (int k = 0; k < 4; ++k) {
    Primitive w;
    w.shape = Primitive::Shape::kBox;
    w.kind = SurfaceKind::kWall;
    w.T_world_local = At(0.0, 0.0, 3.0, k * M_PI / 2.0) * At(12.0, 0.0, 0.0);
    w.half_extents = Eigen::Vector3d(0.2, 12.0, 3.0);
    scene.Add(w);
  }
  for (int k = 0; k < 3; ++k) {
    const double yaw = (k - 1) * 0.5;
    const Pose T_world_board = At(0.0, 0.0, 0.0, yaw) * BoardFacingOrigin(4.0 + k, 1.4);
    AddBoard(&scene, T_world_board);
    Primitive stand;
    stand.shape = Primitive::Shape::kCylinder;
    stand.kind = SurfaceKind::kStand;
    stand.T_world_local = At(0.0, 0.0, 0.0, yaw) * At(4.05 + k, 0.0, 0.0);
    stand.radius = 0.03;
    stand.height = 1.0;
    scene.Add(stand);
  }
  for (int k = 0; k < 20; ++k) {
    Primitive c;
    const double a = 0.7 * k, r = 6.0 + 0.25 * k;
    c.kind = SurfaceKind::kClutter;
    if (k % 2 == 0) {
      c.shape = Primitive::Shape::kBox;
      c.T_world_local = At(r * std::cos(a), r * std::sin(a), 0.4, a);
      c.half_extents = Eigen::Vector3d(0.3, 0.5, 0.4);
    } else {
      c.shape = Primitive::Shape::kCylinder;
      c.T_world_local = At(r * std::cos(a), r * std::sin(a), 0.0);
      c.radius = 0.2;
      c.height = 1.2;
    }
    scene.Add(c);
  }
  scene.Finalize();
  return scene;
}

// Not a timed assertion: prints the cost per frame for the report (Release builds only matter).
TEST(LidarSimTest, ReportsTimeAndPointsPerFrame) {
  const Scene scene = WorkshopScene();
  ASSERT_GE(scene.primitives.size(), 30u);
  const Pose start = At(0.0, 0.0, 1.6), end = At(0.05, 0.0, 1.6, 0.01);
  for (LidarKind kind : {LidarKind::kOt128, LidarKind::kM1, LidarKind::kFalcon}) {
    LidarSimulator sim(MakeLidarModel(kind), LidarNoise());
    LidarScan scan;
    sim.Scan(scene, start, end, 0, 1, &scan);  // warm-up: pattern and buffers
    constexpr int kFrames = 5;
    const auto t0 = std::chrono::steady_clock::now();
    for (int f = 0; f < kFrames; ++f) sim.Scan(scene, start, end, f, 1 + f, &scan);
    const double ms = MsSince(t0) / kFrames;
    int on_boards = 0;
    for (int16_t b : scan.board) on_boards += b >= 0;
    std::cout << "[ lidar    ] " << sim.model().name << ": " << ms << " ms/frame, " << scan.size()
              << " points, " << on_boards << " on boards\n";
    EXPECT_GT(scan.size(), 0u);
  }
}

}  // namespace
}  // namespace calibd::sim
