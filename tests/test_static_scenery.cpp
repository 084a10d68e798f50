// FindStaticScenery (static_scenery.hpp): clusters that stand still in the LiDAR frame while the
// camera's boards move are dropped; boards that move, boards that stand still and everything of
// a moving vehicle are kept.

#include "calibd/core/session/static_scenery.hpp"

#include <gtest/gtest.h>

#include <random>
#include <vector>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {
namespace {

// A w x h planar patch of points facing -x (towards a LiDAR at the origin) around `centre`,
// turned by `yaw` about z, with 1 cm of noise.
std::vector<Eigen::Vector3f> Patch(const Eigen::Vector3d& centre, double yaw, double w, double h,
                                   std::mt19937_64* rng) {
  std::normal_distribution<double> noise(0.0, 0.01);
  const Eigen::Matrix3d R = RotationFromRpy(0.0, 0.0, yaw);
  std::vector<Eigen::Vector3f> out;
  for (double u = -w / 2; u <= w / 2; u += 0.05)
    for (double v = -h / 2; v <= h / 2; v += 0.05)
      out.push_back((centre + R * Eigen::Vector3d(noise(*rng), u, v)).cast<float>());
  return out;
}

// One board and one cabinet front, `frames` frames. The board is at board_at(k) in the LiDAR
// frame; the camera sees it there through a fixed extrinsic (the LiDAR's axes turned to the
// camera's). The cabinet is at cabinet_at(k), seen by the LiDAR only.
template <typename BoardAt, typename CabinetAt>
SessionObservations MakeSession(int frames, BoardAt board_at, CabinetAt cabinet_at) {
  std::mt19937_64 rng(7);
  Pose T_camera_lidar = Pose::Identity();
  T_camera_lidar.linear() = RotationFromRpy(-90.0 * kDeg2Rad, 0.0, -90.0 * kDeg2Rad);
  T_camera_lidar.translation() = Eigen::Vector3d(0.1, -0.2, 0.05);
  SessionObservations s;
  s.Reserve(frames, 2, 1024);
  for (int k = 0; k < frames; ++k) {
    EXPECT_TRUE(s.BeginFrame());
    const Eigen::Vector3d board = board_at(k);
    SessionObservations::CameraBoard b;
    b.board_index = 0;
    // The board's frame: x along the patch's width (LiDAR y), y along its height (LiDAR z), z
    // its normal (LiDAR x), turned with the patch.
    Eigen::Matrix3d axes;
    axes.col(0) = Eigen::Vector3d::UnitY();
    axes.col(1) = Eigen::Vector3d::UnitZ();
    axes.col(2) = Eigen::Vector3d::UnitX();
    Pose T_lidar_board = Pose::Identity();
    T_lidar_board.linear() = RotationFromRpy(0.0, 0.0, 0.1 * k) * axes;
    T_lidar_board.translation() = board;
    b.T_camera_board = T_camera_lidar * T_lidar_board;
    EXPECT_TRUE(s.AddCameraBoard(b));
    const auto board_points = Patch(board, 0.1 * k, 0.8, 1.0, &rng);
    EXPECT_TRUE(
        s.AddLidarCluster(board_points.data(), nullptr, static_cast<int>(board_points.size())));
    // The cabinet's visible part changes a little from frame to frame (people, the board).
    const double w = 0.9 + 0.1 * (k % 3);
    const auto cabinet = Patch(cabinet_at(k), 0.0, w, 0.9, &rng);
    EXPECT_TRUE(s.AddLidarCluster(cabinet.data(), nullptr, static_cast<int>(cabinet.size())));
  }
  return s;
}

std::vector<BoardGeometry> Boards() {
  BoardGeometry g;
  g.width_m = 0.8;
  g.height_m = 1.0;
  return {g};
}

TEST(StaticSceneryTest, AFrontThatStaysWhileTheBoardMovesIsScenery) {
  // Still poses: the board goes somewhere else in every shot; the cabinet stays.
  const SessionObservations s = MakeSession(
      12,
      [](int k) { return Eigen::Vector3d(2.0 + 0.3 * k, 1.5 * std::sin(1.3 * k), 0.2 * (k % 3)); },
      [](int) { return Eigen::Vector3d(6.0, -3.0, -0.8); });
  const StaticScenery scenery = FindStaticScenery(s, Boards(), StaticSceneryConfig{});
  ASSERT_EQ(scenery.scenery.size(), s.lidar.size());
  for (size_t j = 0; j < s.lidar.size(); ++j)
    EXPECT_EQ(scenery.scenery[j], j % 2 == 1 ? 1 : 0) << "cluster " << j;
  EXPECT_EQ(scenery.num_scenery, 12);

  StaticSceneryConfig off;
  off.enabled = false;
  EXPECT_EQ(FindStaticScenery(s, Boards(), off).num_scenery, 0);
}

TEST(StaticSceneryTest, ABoardThatStandsStillIsKept) {
  // Shots of a board that was not moved: it stays, and so does the camera's board.
  const SessionObservations s = MakeSession(
      8, [](int) { return Eigen::Vector3d(4.0, 0.5, 0.0); },
      [](int) { return Eigen::Vector3d(6.0, -3.0, -0.8); });
  const StaticScenery scenery = FindStaticScenery(s, Boards(), StaticSceneryConfig{});
  for (size_t j = 0; j < s.lidar.size(); j += 2) EXPECT_EQ(scenery.scenery[j], 0);
}

TEST(StaticSceneryTest, NothingIsDroppedOnADrive) {
  // A vehicle driving past: board and cabinet both move in the LiDAR frame, 1 m per frame.
  const SessionObservations s = MakeSession(
      10, [](int k) { return Eigen::Vector3d(20.0 - 1.0 * k, 3.0, 0.0); },
      [](int k) { return Eigen::Vector3d(25.0 - 1.0 * k, -4.0, -0.8); });
  EXPECT_EQ(FindStaticScenery(s, Boards(), StaticSceneryConfig{}).num_scenery, 0);
}

TEST(StaticSceneryTest, TheEngineSolvesFromTheMovingBoardsAndNamesTheirClusters) {
  // The first session above: the engine drops the cabinet and pairs each camera board with its
  // board cluster; every correspondence names that cluster in the session it was given (board
  // clusters are the even ones), not in the subset left after the scenery step.
  const SessionObservations s = MakeSession(
      12,
      [](int k) { return Eigen::Vector3d(2.0 + 0.3 * k, 1.5 * std::sin(1.3 * k), 0.2 * (k % 3)); },
      [](int) { return Eigen::Vector3d(6.0, -3.0, -0.8); });
  CalibConfig config;
  config.boards = Boards();
  config.prior_T_camera_lidar.linear() = RotationFromRpy(-90.0 * kDeg2Rad, 0.0, -90.0 * kDeg2Rad);
  config.prior_T_camera_lidar.translation() = Eigen::Vector3d(0.1, -0.2, 0.05);
  const RangeImage projection = SessionProjection(MakeLidarModel(LidarKind::kVlp16));
  ObservationSet correspondences;
  EngineConfig engine;  // no image corners here: the board poses are held as given
  engine.direct.refine_board_poses = false;
  const CalibrationOutcome outcome = Calibrate(config, s, projection, engine, &correspondences);
  EXPECT_EQ(outcome.static_scenery_clusters, 12);
  ASSERT_EQ(correspondences.observations.size(), 12u);
  for (const BoardObservation& o : correspondences.observations)
    EXPECT_EQ(o.lidar_cluster, 2 * o.frame) << "frame " << o.frame;
}

TEST(StaticSceneryTest, BadConfigIsRefusedNamingTheField) {
  StaticSceneryConfig c;
  std::string why;
  c.max_normal_angle_deg = 0.0;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("max_normal_angle_deg"), std::string::npos);
  c = StaticSceneryConfig{};
  c.max_plane_distance_m = -1.0;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("max_plane_distance_m"), std::string::npos);
  c = StaticSceneryConfig{};
  c.min_frames = 0;
  EXPECT_FALSE(c.IsValid(&why));
  EXPECT_NE(why.find("min_frames"), std::string::npos);
}

}  // namespace
}  // namespace calibd
