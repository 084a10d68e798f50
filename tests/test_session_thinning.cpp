// Fixed memory for long sessions: the session store thinned to every other run of frames when
// it runs short of room, the kept frames spread over the whole session, each with its own
// boards, clusters and points, in a store that never grows.

#include "calibd/core/session/session_thinning.hpp"

#include <gtest/gtest.h>

namespace calibd {
namespace {

constexpr int kMaxFrames = 24;
constexpr int kPoints = 4;  // per cluster

// Frame `arrival`: one camera board and one cluster whose values all carry the arrival number.
void AddMarkedFrame(int64_t arrival, SessionObservations* s) {
  ASSERT_TRUE(s->BeginFrame(FrameTimes{arrival * 100000, arrival * 100000 + 10}));
  SessionObservations::CameraBoard b;
  b.board_index = 0;
  b.T_camera_board.translation() = Eigen::Vector3d(static_cast<double>(arrival), 0, 0);
  ASSERT_TRUE(s->AddCameraBoard(b));
  Eigen::Vector3f pts[kPoints];
  for (auto& p : pts) p = Eigen::Vector3f(static_cast<float>(arrival), 1, 2);
  ASSERT_TRUE(s->AddLidarCluster(pts, nullptr, kPoints));
}

// Every kept frame is whole and consistent: its board, cluster and points carry its arrival.
std::vector<int64_t> CheckAndListArrivals(const SessionObservations& s) {
  std::vector<int64_t> arrivals;
  EXPECT_EQ(s.camera.size(), static_cast<size_t>(s.num_frames));
  EXPECT_EQ(s.lidar.size(), static_cast<size_t>(s.num_frames));
  EXPECT_EQ(s.points.size(), static_cast<size_t>(s.num_frames * kPoints));
  for (int f = 0; f < s.num_frames; ++f) {
    const int64_t a = s.frame_times[static_cast<size_t>(f)].camera_utime / 100000;
    arrivals.push_back(a);
    EXPECT_EQ(s.camera[static_cast<size_t>(f)].frame, f);
    EXPECT_EQ(s.camera[static_cast<size_t>(f)].T_camera_board.translation().x(),
              static_cast<double>(a));
    const auto& c = s.lidar[static_cast<size_t>(f)];
    EXPECT_EQ(c.frame, f);
    EXPECT_EQ(c.first_point, f * kPoints);
    for (int i = 0; i < kPoints; ++i) {
      EXPECT_EQ(s.points[static_cast<size_t>(c.first_point + i)].x(), static_cast<float>(a));
      EXPECT_NEAR(s.point_dt[static_cast<size_t>(c.first_point + i)], 10e-6f, 1e-9f);
    }
  }
  return arrivals;
}

TEST(SessionThinningTest, ALongSessionStaysInItsStoreSpreadOverTheWholeSession) {
  SessionObservations s;
  s.Reserve(kMaxFrames, 1, kPoints);
  const auto* points_data = s.points.data();
  const size_t capacity = s.points.capacity();
  SessionThinning thinning;
  thinning.Reset(kMaxFrames, kPoints, 2);
  int64_t arrival = 0;
  for (int step = 0; step < 200; ++step) {
    const int first_new = s.num_frames;
    AddMarkedFrame(arrival++, &s);
    if (step % 3 == 0) AddMarkedFrame(arrival++, &s);  // sometimes two pairs per drain
    thinning.Apply(first_new, &s);
    ASSERT_LE(s.num_frames + 2, kMaxFrames) << "room for the next drain";
  }
  EXPECT_EQ(s.points.data(), points_data);  // never reallocated
  EXPECT_EQ(s.points.capacity(), capacity);
  const std::vector<int64_t> kept = CheckAndListArrivals(s);
  ASSERT_GE(kept.size(), static_cast<size_t>(kMaxFrames / 2 - 2));
  const int64_t run = SessionThinning::kRun, stride = thinning.stride();
  EXPECT_GT(stride, 1);
  for (size_t i = 0; i < kept.size(); ++i) {
    EXPECT_EQ((kept[i] / run) % stride, 0) << "frame " << kept[i] << " is off the stride";
    if (i > 0) {
      EXPECT_GT(kept[i], kept[i - 1]);
    }
    // Runs of kRun consecutive arrivals: motion compensation keeps its neighbours.
    if (kept[i] % run != 0) {
      EXPECT_EQ(kept[i - 1], kept[i] - 1);
    }
  }
  // Spread over the whole session, not its first part: the first run and one near the end.
  EXPECT_EQ(kept.front(), 0);
  EXPECT_GE(kept.back(), arrival - run * stride);
}

TEST(SessionThinningTest, AShortSessionKeepsEveryFrame) {
  SessionObservations s;
  s.Reserve(kMaxFrames, 1, kPoints);
  SessionThinning thinning;
  thinning.Reset(kMaxFrames, kPoints, 2);
  for (int64_t a = 0; a < kMaxFrames - 2; ++a) {
    const int first_new = s.num_frames;
    AddMarkedFrame(a, &s);
    thinning.Apply(first_new, &s);
  }
  EXPECT_EQ(thinning.stride(), 1);
  const std::vector<int64_t> kept = CheckAndListArrivals(s);
  ASSERT_EQ(kept.size(), static_cast<size_t>(kMaxFrames - 2));
  for (size_t i = 0; i < kept.size(); ++i) EXPECT_EQ(kept[i], static_cast<int64_t>(i));
}

TEST(SessionThinningTest, ThePointPoolRunningShortThinsToo) {
  SessionObservations s;
  s.Reserve(kMaxFrames, 1, kPoints);  // room for kMaxFrames x kPoints points
  SessionThinning thinning;
  // Worst-case frames of 3 clusters' worth: the pool, not the frame count, is short first.
  thinning.Reset(kMaxFrames, 3 * kPoints, 2);
  for (int64_t a = 0; a < 60; ++a) {
    const int first_new = s.num_frames;
    AddMarkedFrame(a, &s);
    thinning.Apply(first_new, &s);
    ASSERT_LE(s.points.size() + 2 * 3 * kPoints, s.points.capacity());
  }
  EXPECT_GT(thinning.stride(), 1);
  CheckAndListArrivals(s);
}

TEST(SessionThinningTest, RemoveFramesKeepsTheRestInOrder) {
  SessionObservations s;
  s.Reserve(8, 1, kPoints);
  for (int64_t a = 0; a < 6; ++a) AddMarkedFrame(a, &s);
  RemoveFrames({1, 0, 0, 1, 0, 1}, &s);
  EXPECT_EQ(CheckAndListArrivals(s), (std::vector<int64_t>{0, 3, 5}));
}

}  // namespace
}  // namespace calibd
