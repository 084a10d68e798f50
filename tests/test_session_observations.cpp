// The session store's frame selection: frames taken in any order, repeated or left out, keep
// their camera boards, clusters, points and times, renumbered in the order taken.

#include <gtest/gtest.h>

#include <vector>

#include "calibd/core/session/session_observations.hpp"

namespace calibd {
namespace {

// Three frame pairs: frame f has camera time 1 s + f x 0.1 s and its sweep 30 ms earlier, one
// camera board (index f), and f + 1 clusters of 2 points at x = 10 f + cluster, fired 1 ms and
// 2 ms after the sweep start. Frame 1 has no camera board at all.
SessionObservations ThreeFrames() {
  SessionObservations s;
  s.Reserve(3, 3, 2);
  for (int f = 0; f < 3; ++f) {
    const int64_t camera_us = 1000000 + 100000 * f;
    EXPECT_TRUE(s.BeginFrame(FrameTimes{camera_us, camera_us - 30000}));
    if (f != 1) {
      SessionObservations::CameraBoard board;
      board.board_index = f;
      EXPECT_TRUE(s.AddCameraBoard(board));
    }
    for (int c = 0; c <= f; ++c) {
      const auto x = static_cast<float>(10 * f + c);
      const Eigen::Vector3f points[2] = {{x, 0.0f, 0.0f}, {x, 1.0f, 0.0f}};
      const float fired_s[2] = {0.001f, 0.002f};
      EXPECT_TRUE(s.AddLidarCluster(points, fired_s, 2));
    }
  }
  return s;
}

TEST(SessionObservationsTest, FramesCanBeTakenInAnyOrderRepeatedOrLeftOut) {
  const SessionObservations s = ThreeFrames();
  std::vector<char> all_camera(s.camera.size(), 1), lidar(s.lidar.size(), 1);
  lidar[3] = 0;  // frame 2's first cluster
  const SessionObservations out = SelectFrames(s, {2, 0, 0, 1}, all_camera, lidar);
  ASSERT_EQ(out.num_frames, 4);
  ASSERT_EQ(out.frame_times.size(), 4u);
  EXPECT_EQ(out.frame_times[0].camera_utime, 1200000);
  EXPECT_EQ(out.frame_times[1].camera_utime, 1000000);
  EXPECT_EQ(out.frame_times[3].lidar_utime, 1070000);
  // Camera boards: frame 2's, then frame 0's twice; frame 1 has none.
  ASSERT_EQ(out.camera.size(), 3u);
  EXPECT_EQ(out.camera[0].frame, 0);
  EXPECT_EQ(out.camera[0].board_index, 2);
  EXPECT_EQ(out.camera[2].frame, 2);
  EXPECT_EQ(out.camera[2].board_index, 0);
  // Clusters: frame 2's last two (the first left out), frame 0's twice, frame 1's two.
  ASSERT_EQ(out.lidar.size(), 6u);
  const int expected_frame[6] = {0, 0, 1, 2, 3, 3};
  const float expected_x[6] = {21.0f, 22.0f, 0.0f, 0.0f, 10.0f, 11.0f};
  for (size_t j = 0; j < out.lidar.size(); ++j) {
    EXPECT_EQ(out.lidar[j].frame, expected_frame[j]) << j;
    EXPECT_EQ(out.points[static_cast<size_t>(out.lidar[j].first_point)].x(), expected_x[j]) << j;
  }
  // Firing times stay relative to the camera: the sweep started 30 ms before it.
  ASSERT_EQ(out.point_dt.size(), out.points.size());
  EXPECT_FLOAT_EQ(out.point_dt[0], -0.029f);
  EXPECT_FLOAT_EQ(out.point_dt[1], -0.028f);

  // Subset is the selection of the kept frames in their order.
  const SessionObservations kept = Subset(s, {1, 0, 1}, all_camera, lidar);
  const SessionObservations same = SelectFrames(s, {0, 2}, all_camera, lidar);
  EXPECT_EQ(kept.num_frames, same.num_frames);
  EXPECT_EQ(kept.camera.size(), same.camera.size());
  EXPECT_EQ(kept.lidar.size(), same.lidar.size());
  EXPECT_EQ(kept.points, same.points);
  EXPECT_EQ(kept.point_dt, same.point_dt);
}

}  // namespace
}  // namespace calibd
