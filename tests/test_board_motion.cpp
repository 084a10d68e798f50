// Motion compensation of LiDAR board points (board_motion.hpp): the board velocity fitted from
// camera poses over neighbouring frames, and points fired across a sweep moved back to the
// camera's capture time, on exact kinematics of a turning, driving vehicle; and the camera's time
// offset measured from the boards' motion.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "calibd/core/session/board_motion.hpp"

namespace calibd {
namespace {

constexpr int64_t kStart = 1767225600000000;

// A camera driving towards a static board at 2.5 m/s with a 5 deg/s yaw rate; the LiDAR sits
// 0.4 m above the camera, looking forward (its own axes: x forward, y left, z up).
struct Scene {
  Pose T_world_board = Pose::Identity();
  Pose T_camera_lidar = Pose::Identity();

  Scene() {
    Eigen::Matrix3d R_facing;  // board z towards the camera (world -x), board x along world -y
    R_facing << 0, 0, -1, -1, 0, 0, 0, 1, 0;
    T_world_board.linear() = R_facing;
    T_world_board.translation() = Eigen::Vector3d(12.0, 1.0, 1.5);
    Eigen::Matrix3d R_cl;  // optical frame (x right, y down, z forward) from LiDAR axes
    R_cl << 0, -1, 0, 0, 0, -1, 1, 0, 0;
    T_camera_lidar.linear() =
        R_cl * RotationFromRpy(0.5 * kDeg2Rad, -1.0 * kDeg2Rad, 2.0 * kDeg2Rad);
    T_camera_lidar.translation() = Eigen::Vector3d(0.0, 0.4, -0.2);
  }

  // Camera pose in the world at t (s): optical axis along world x, moving forward and turning.
  Pose T_world_camera(double t) const {
    Eigen::Matrix3d R_wc;  // optical frame in world axes (x forward, y left, z up)
    R_wc << 0, 0, 1, -1, 0, 0, 0, -1, 0;
    Pose T = Pose::Identity();
    T.linear() = RotationFromRpy(0, 0, 5.0 * kDeg2Rad * t) * R_wc;
    T.translation() = Eigen::Vector3d(2.5 * t, 0.1 * t, 1.4);
    return T;
  }
  Pose T_camera_board(double t) const { return T_world_camera(t).inverse() * T_world_board; }
};

int64_t Utime(double t) { return kStart + static_cast<int64_t>(std::llround(t * 1e6)); }

// Ten frames at 10 Hz; the camera sees the board in each; frame_lidar_dt is the sweep start
// relative to the capture.
SessionObservations MakeSession(const Scene& scene, int frames, bool known_times) {
  SessionObservations s;
  s.Reserve(frames, 2, 16);
  for (int k = 0; k < frames; ++k) {
    const double t = 0.1 * k;
    const FrameTimes times = known_times ? FrameTimes{Utime(t), Utime(t - 0.05)} : FrameTimes{};
    EXPECT_TRUE(s.BeginFrame(times));
    SessionObservations::CameraBoard b;
    b.board_index = 0;
    b.T_camera_board = scene.T_camera_board(t);
    EXPECT_TRUE(s.AddCameraBoard(b));
  }
  return s;
}

TEST(BoardMotionTest, VelocityIsTheBoardsApparentVelocityInTheCameraFrame) {
  const Scene scene;
  const SessionObservations s = MakeSession(scene, 10, true);
  const MotionCompensationConfig config;
  for (int k : {2, 5, 7}) {
    const double t = 0.1 * k, h = 1e-4;
    const Eigen::Vector3d expected =
        (scene.T_camera_board(t + h).translation() - scene.T_camera_board(t - h).translation()) /
        (2 * h);
    Eigen::Vector3d u;
    ASSERT_TRUE(EstimateBoardVelocity(s, k, 0, config, &u)) << "frame " << k;
    EXPECT_LT((u - expected).norm(), 0.01)
        << "frame " << k << ": " << u.transpose() << " vs " << expected.transpose();
    EXPECT_GT(u.norm(), 2.0);  // it is really moving
  }
}

TEST(BoardMotionTest, AFramesOwnDetectionDoesNotEnterItsVelocity) {
  // The frame's own PnP noise must not enter its velocity: it enters its camera distance too,
  // and the time offset's fit (camera minus LiDAR distance against the normal speed) would read
  // that shared noise as an offset: still poses, whose boards do not move, measured 0.2-0.3 s at
  // 3-4 sigma (tuning seed 24, sessions 207 and 253). Frame 5's board moved 5 cm along the
  // optical axis: its own velocity stays, its neighbours' change.
  const Scene scene;
  SessionObservations s = MakeSession(scene, 10, true);
  const MotionCompensationConfig config;
  Eigen::Vector3d before5, before4, after5, after4;
  ASSERT_TRUE(EstimateBoardVelocity(s, 5, 0, config, &before5));
  ASSERT_TRUE(EstimateBoardVelocity(s, 4, 0, config, &before4));
  for (auto& b : s.camera)
    if (b.frame == 5) b.T_camera_board.translation().z() += 0.05;
  ASSERT_TRUE(EstimateBoardVelocity(s, 5, 0, config, &after5));
  ASSERT_TRUE(EstimateBoardVelocity(s, 4, 0, config, &after4));
  EXPECT_LT((after5 - before5).norm(), 1e-12);
  EXPECT_GT((after4 - before4).norm(), 0.05);
  // The first frame has neighbours on one side only (0.1 and 0.2 s later): the span counts its
  // own time, so it still has a velocity.
  Eigen::Vector3d first;
  EXPECT_TRUE(EstimateBoardVelocity(s, 0, 0, config, &first));
}

TEST(BoardMotionTest, NoVelocityWithoutTimesNeighboursOrPlausibleSpeed) {
  const Scene scene;
  const MotionCompensationConfig config;
  Eigen::Vector3d u = Eigen::Vector3d::Constant(7.0);
  // Times unknown (all zero): the samples span no time.
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 10, false), 5, 0, config, &u));
  // A lone frame, and a board index never seen.
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 1, true), 0, 0, config, &u));
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 10, true), 5, 1, config, &u));
  // Out-of-range frames.
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 10, true), 10, 0, config, &u));
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 10, true), -1, 0, config, &u));
  // Implausibly fast: a mismatch, not a motion.
  MotionCompensationConfig slow = config;
  slow.max_speed_mps = 1.0;
  EXPECT_FALSE(EstimateBoardVelocity(MakeSession(scene, 10, true), 5, 0, slow, &u));
  EXPECT_EQ(u, Eigen::Vector3d::Constant(7.0));  // untouched on failure
  std::string error;
  slow.min_samples = 1;
  EXPECT_FALSE(slow.IsValid(&error));
  EXPECT_NE(error.find("min_samples"), std::string::npos);
}

// Frames further apart than the window leave every board without a velocity, and the stats say
// why (the window is not widened by itself: see MotionCompensationConfig::window_s).
TEST(BoardMotionTest, FramesFurtherApartThanTheWindowAreNamed) {
  const Scene scene;
  EXPECT_NEAR(MedianFrameInterval(MakeSession(scene, 10, true)), 0.1, 1e-6);
  EXPECT_EQ(MedianFrameInterval(MakeSession(scene, 10, false)), 0.0);  // times unknown
  SessionObservations s;
  s.Reserve(3, 2, 16);
  for (int k = 0; k < 3; ++k) {
    ASSERT_TRUE(s.BeginFrame(FrameTimes{Utime(1.0 * k), Utime(1.0 * k - 0.05)}));
    SessionObservations::CameraBoard b;
    b.board_index = 0;
    b.T_camera_board = scene.T_camera_board(1.0 * k);
    ASSERT_TRUE(s.AddCameraBoard(b));
  }
  ObservationSet set;
  set.Reserve(1, 1);
  BoardObservation o;
  o.frame = 1;
  o.board_index = 0;
  o.T_camera_board = scene.T_camera_board(1.0);
  const Eigen::Vector3f p = Eigen::Vector3f::Zero();
  const float dt = -0.05f;
  ASSERT_TRUE(set.Add(o, &p, &dt, 1));
  ObservationSet again = set;
  MotionCompensationConfig config;
  const MotionCompensationStats stats =
      CompensateBoardMotion(s, scene.T_camera_lidar, config, &set);
  EXPECT_NEAR(stats.frame_interval_s, 1.0, 1e-6);
  EXPECT_EQ(stats.window_s, config.window_s);
  EXPECT_TRUE(stats.FramesBeyondWindow());
  // The window the stats suggest (1.5 intervals) measures it.
  config.window_s = 1.5;
  const MotionCompensationStats wide =
      CompensateBoardMotion(s, scene.T_camera_lidar, config, &again);
  EXPECT_EQ(wide.compensated, 1);
  EXPECT_FALSE(wide.FramesBeyondWindow());
}

TEST(BoardMotionTest, PointsFiredAcrossTheSweepReturnToTheCaptureTime) {
  const Scene scene;
  const SessionObservations s = MakeSession(scene, 10, true);
  const int frame = 5;
  const double t_cam = 0.1 * frame;
  // Board points fired top to bottom over 0.1 s from the sweep start (0.05 s before the
  // capture), each seen in the LiDAR frame of its own firing time.
  std::vector<Eigen::Vector3f> points;
  std::vector<float> dt;
  std::vector<Eigen::Vector3d> at_capture;  // where the camera-time LiDAR frame sees them
  const Pose T_lidar_camera = scene.T_camera_lidar.inverse();
  for (int row = 0; row < 12; ++row) {
    for (int col = 0; col < 12; ++col) {
      const Eigen::Vector3d p_board(-0.275 + 0.05 * col, 0.275 - 0.05 * row, 0.0);
      const double t_fire = t_cam - 0.05 + 0.1 * row / 11.0;
      const Eigen::Vector3d p_world = scene.T_world_board * p_board;
      points.push_back(
          (T_lidar_camera * scene.T_world_camera(t_fire).inverse() * p_world).cast<float>());
      dt.push_back(static_cast<float>(t_fire - t_cam));
      at_capture.push_back(T_lidar_camera * scene.T_world_camera(t_cam).inverse() * p_world);
    }
  }
  ObservationSet set;
  set.Reserve(1, static_cast<int>(points.size()));
  BoardObservation o;
  o.frame = frame;
  o.board_index = 0;
  o.T_camera_board = scene.T_camera_board(t_cam);
  ASSERT_TRUE(set.Add(o, points.data(), dt.data(), static_cast<int>(points.size())));

  double before = 0.0;
  for (size_t i = 0; i < points.size(); ++i)
    before = std::max(before, (points[i].cast<double>() - at_capture[i]).norm());
  const MotionCompensationStats stats =
      CompensateBoardMotion(s, scene.T_camera_lidar, MotionCompensationConfig{}, &set);
  EXPECT_EQ(stats.compensated, 1);
  EXPECT_EQ(stats.uncompensated, 0);
  EXPECT_TRUE(set.motion_compensated);
  EXPECT_TRUE(set.observations[0].has_velocity);
  double after = 0.0;
  for (size_t i = 0; i < points.size(); ++i)
    after = std::max(after, (set.points[i].cast<double>() - at_capture[i]).norm());
  EXPECT_GT(before, 0.1);   // 2.5 m/s over 0.05 s, plus the turn
  EXPECT_LT(after, 0.003);  // first order in time, one velocity per board
  EXPECT_NEAR(stats.max_shift_m, before, 0.01);

  // Applying it again changes nothing; disabled, nothing moves.
  const std::vector<Eigen::Vector3f> once = set.points;
  CompensateBoardMotion(s, scene.T_camera_lidar, MotionCompensationConfig{}, &set);
  EXPECT_EQ(set.points, once);
  set.motion_compensated = false;
  MotionCompensationConfig off;
  off.enabled = false;
  EXPECT_EQ(CompensateBoardMotion(s, scene.T_camera_lidar, off, &set).compensated, 0);
  EXPECT_EQ(set.points, once);
}

// A board the camera saw in only one frame (no neighbours in the window) has no velocity: while
// the boards move, its observation is dropped (its points are where the LiDAR saw the board, not
// where the camera did); while they stand still, it is kept.
TEST(BoardMotionTest, AnObservationWhoseMotionIsUnknownIsDroppedOnlyWhileBoardsMove) {
  for (const bool moving : {true, false}) {
    SCOPED_TRACE(moving ? "moving" : "still");
    const Scene scene;
    auto camera_board = [&](double t) { return scene.T_camera_board(moving ? t : 0.0); };
    SessionObservations s;
    s.Reserve(16, 2, 16);
    for (int k = 0; k < 16; ++k) {
      const double t = 0.1 * k;
      ASSERT_TRUE(s.BeginFrame(FrameTimes{Utime(t), Utime(t - 0.05)}));
      if (k >= 10 && k != 15) continue;  // frames 10-14 without the board: 15 stands alone
      SessionObservations::CameraBoard b;
      b.board_index = 0;
      b.T_camera_board = camera_board(t);
      ASSERT_TRUE(s.AddCameraBoard(b));
    }
    ObservationSet set;
    set.Reserve(2, 8);
    const std::vector<float> dt(4, -0.05f);
    for (const int frame : {5, 15}) {
      BoardObservation o;
      o.frame = frame;
      o.board_index = 0;
      o.T_camera_board = camera_board(0.1 * frame);
      const Eigen::Vector3f p =
          (scene.T_camera_lidar.inverse() * o.T_camera_board.translation()).cast<float>();
      const std::vector<Eigen::Vector3f> points(4, p);
      ASSERT_TRUE(set.Add(o, points.data(), dt.data(), 4));
    }
    const MotionCompensationStats stats =
        CompensateBoardMotion(s, scene.T_camera_lidar, MotionCompensationConfig{}, &set);
    EXPECT_EQ(stats.uncompensated, 1);
    if (moving) {
      EXPECT_NEAR(stats.median_shift_m, 2.5 * 0.05, 0.02);  // 2.5 m/s, 0.05 s before the capture
      EXPECT_EQ(stats.dropped, 1);
      ASSERT_EQ(set.observations.size(), 1u);
      EXPECT_EQ(set.observations[0].frame, 5);
      EXPECT_EQ(set.observations[0].first_point, 0);
      EXPECT_EQ(set.points.size(), 4u);
    } else {
      EXPECT_LT(stats.median_shift_m, 1e-9);
      EXPECT_EQ(stats.dropped, 0);
      ASSERT_EQ(set.observations.size(), 2u);
      EXPECT_FALSE(set.observations[1].has_velocity);
    }
  }
}

// Three observations, frames 0-2, frame k with k + 1 points (k, i, 0), i = 0..k, fired
// 0.01 (10 k + i) s from the capture.
ObservationSet ThreeObservations() {
  ObservationSet set;
  set.Reserve(3, 6);
  for (int k = 0; k < 3; ++k) {
    BoardObservation o;
    o.frame = k;
    std::vector<Eigen::Vector3f> points;
    std::vector<float> dt;
    for (int i = 0; i <= k; ++i) {
      points.emplace_back(static_cast<float>(k), static_cast<float>(i), 0.0f);
      dt.push_back(0.01f * static_cast<float>(10 * k + i));
    }
    EXPECT_TRUE(set.Add(o, points.data(), dt.data(), k + 1));
  }
  return set;
}

// Each observation of `set` holds the points of ThreeObservations() numbered `kept[frame]`.
void ExpectPoints(const ObservationSet& set, const std::vector<std::vector<int>>& kept) {
  int first = 0;
  for (const BoardObservation& o : set.observations) {
    const std::vector<int>& want = kept[static_cast<size_t>(o.frame)];
    EXPECT_EQ(o.first_point, first);
    ASSERT_EQ(o.num_points, static_cast<int>(want.size()));
    for (int j = 0; j < o.num_points; ++j) {
      const auto p = static_cast<size_t>(o.first_point + j);
      const int i = want[static_cast<size_t>(j)];
      EXPECT_EQ(set.points[p].x(), static_cast<float>(o.frame));
      EXPECT_EQ(set.points[p].y(), static_cast<float>(i));
      EXPECT_FLOAT_EQ(set.point_dt[p], 0.01f * static_cast<float>(10 * o.frame + i));
    }
    first += o.num_points;
  }
  EXPECT_EQ(set.points.size(), static_cast<size_t>(first));
  EXPECT_EQ(set.point_dt.size(), static_cast<size_t>(first));
}

TEST(BoardObservationTest, KeepOnlyKeepsTheChosenObservationsWithTheirPoints) {
  ObservationSet set = ThreeObservations();
  EXPECT_EQ(set.KeepOnly({0, 1, 1}), 1);
  ASSERT_EQ(set.observations.size(), 2u);
  ExpectPoints(set, {{}, {0, 1}, {0, 1, 2}});
}

TEST(BoardObservationTest, KeepPointsKeepsTheChosenPointsOfEveryObservation) {
  // Frame 1's first point and frame 2's middle one dropped.
  ObservationSet set = ThreeObservations();
  EXPECT_EQ(set.KeepPoints({1, 0, 1, 1, 0, 1}), 2);
  ASSERT_EQ(set.observations.size(), 3u);
  ExpectPoints(set, {{0}, {1}, {0, 2}});
}

// Compensated observations of three boards turned differently whose apparent velocity along the
// camera's axis follows `speed(k)` (frame k), seen by a camera `offset_s` later than its stamps:
// the camera's board pose is where the board was then, the points where it was at the stamp
// (offset_s u earlier). Points lie on the boards' planes, with the LiDAR frame of `scene`.
ObservationSet MovingBoards(const Scene& scene, double offset_s, double (*speed)(int)) {
  ObservationSet set;
  set.Reserve(300, 300 * 25);
  for (int k = 0; k < 100; ++k) {
    for (int b = 0; b < 3; ++b) {
      BoardObservation o;
      o.frame = k;
      o.board_index = b;
      const double roll_deg[] = {15.0, -10.0, 20.0}, pitch_deg[] = {-25.0, 5.0, 30.0};
      o.T_camera_board.linear() =
          RotationFromRpy(roll_deg[b] * kDeg2Rad, M_PI + pitch_deg[b] * kDeg2Rad, 0.0);
      o.T_camera_board.translation() = Eigen::Vector3d((b - 1) * 2.0, 0.3 * b, 8.0 + 0.05 * k);
      o.velocity = Eigen::Vector3d(0.1 * (b - 1), 0.0, speed(k));
      o.has_velocity = true;
      for (int c = 0; c < 4; ++c)  // a 40 px tag
        o.corners_px[c] =
            Eigen::Vector2d(500.0 + 40.0 * (c == 1 || c == 2), 300.0 + 40.0 * (c >= 2));
      std::vector<Eigen::Vector3f> points;
      for (int i = 0; i < 25; ++i) {
        const Eigen::Vector3d on_board(-0.4 + 0.2 * (i % 5), -0.4 + 0.2 * (i / 5), 0.0);
        const Eigen::Vector3d p_camera = o.T_camera_board * on_board - offset_s * o.velocity;
        points.push_back((scene.T_camera_lidar.inverse() * p_camera).cast<float>());
      }
      EXPECT_TRUE(set.Add(o, points.data(), nullptr, static_cast<int>(points.size())));
    }
  }
  set.motion_compensated = true;
  return set;
}

TEST(BoardMotionTest, TheCamerasTimeOffsetIsMeasuredFromBoardsMovingBothWays) {
  const Scene scene;
  // Back and forth: 2.5 m/s towards, then away.
  auto both_ways = [](int k) { return 2.5 * std::cos(2.0 * M_PI * k / 100.0); };
  ObservationSet set = MovingBoards(scene, 0.03, both_ways);
  const TimeOffsetEstimate t = EstimateTimeOffset(set, scene.T_camera_lidar);
  ASSERT_TRUE(t.fitted);
  EXPECT_NEAR(t.offset_s, 0.03, 1e-4);
  EXPECT_LT(t.sigma_s, 1e-3);
  EXPECT_NEAR(t.normal_speed_rms_mps, 2.5 / std::sqrt(2.0), 0.2);
  EXPECT_EQ(t.observations, 300);

  // Moved to the camera's capture time, nothing is left of it.
  ShiftToCaptureTime(t.offset_s, scene.T_camera_lidar, &set);
  EXPECT_DOUBLE_EQ(set.time_offset_s, t.offset_s);
  const TimeOffsetEstimate after = EstimateTimeOffset(set, scene.T_camera_lidar);
  ASSERT_TRUE(after.fitted);
  EXPECT_NEAR(after.offset_s, 0.0, 1e-4);

  // A clean session measures none.
  const TimeOffsetEstimate clean =
      EstimateTimeOffset(MovingBoards(scene, 0.0, both_ways), scene.T_camera_lidar);
  ASSERT_TRUE(clean.fitted);
  EXPECT_NEAR(clean.offset_s, 0.0, 1e-4);
}

TEST(BoardMotionTest, AtASteadySpeedTowardsTheBoardsTheOffsetIsATranslation) {
  const Scene scene;
  // Every board approaches at 2.5 m/s: offset_s u is the same shift in every frame, which a
  // translation explains as well, so the offset cannot be measured.
  const TimeOffsetEstimate t =
      EstimateTimeOffset(MovingBoards(scene, 0.03, [](int) { return -2.5; }), scene.T_camera_lidar);
  EXPECT_TRUE(!t.fitted || t.sigma_s * t.normal_speed_rms_mps > 0.01)
      << t.offset_s << " +- " << t.sigma_s;
  // Without motion compensation there is nothing to measure it from.
  ObservationSet uncompensated = MovingBoards(scene, 0.03, [](int) { return -2.5; });
  uncompensated.motion_compensated = false;
  EXPECT_FALSE(EstimateTimeOffset(uncompensated, scene.T_camera_lidar).fitted);
}

}  // namespace
}  // namespace calibd
