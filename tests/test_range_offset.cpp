// The LiDAR range offset from the boards' in-plane centres (range_offset.hpp): a drive towards two
// boards left and right of the LiDAR's axis, which the plane distances alone cannot tell from a
// translation, measures it; points beside a board (a person, a stand) do not move it.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/verdict/range_offset.hpp"

namespace calibd {
namespace {

// 60 frames approaching two 0.6 m boards 1.1 m left and right of the axis from 14 m to 4 m, facing
// the LiDAR (at the camera's origin: T_camera_lidar = identity), scanned every 0.2 deg in azimuth
// and elevation with 1 cm range noise; every range `offset_m` long. `beside` adds a strip of
// points 0.2 m beside each board's outer edge, on its plane.
ObservationSet Drive(double offset_m, bool beside) {
  ObservationSet set;
  set.Reserve(120, 120 * 2000);
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.01);
  std::vector<Eigen::Vector3f> points;
  for (int frame = 0; frame < 60; ++frame) {
    const double z = 14.0 - 10.0 * frame / 59.0;
    for (int board = 0; board < 2; ++board) {
      BoardObservation o;
      o.frame = frame;
      o.board_index = board;
      o.T_camera_board.linear() =
          Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
      o.T_camera_board.translation() = Eigen::Vector3d(board == 0 ? -1.1 : 1.1, 0.0, z);
      const double side_px = 1100.0 * 0.48 / z;
      o.corners_px = {Eigen::Vector2d(0, 0), Eigen::Vector2d(side_px, 0),
                      Eigen::Vector2d(side_px, side_px), Eigen::Vector2d(0, side_px)};
      points.clear();
      const Eigen::Vector3d c = o.T_camera_board.translation();
      const double half_extent = std::atan2(0.6, z) + 0.01;
      const double az0 = std::atan2(c.x(), c.z());
      for (double az = az0 - half_extent; az <= az0 + half_extent; az += 0.2 * kDeg2Rad)
        for (double el = -half_extent; el <= half_extent; el += 0.2 * kDeg2Rad) {
          const Eigen::Vector3d u(std::sin(az) * std::cos(el), std::sin(el),
                                  std::cos(az) * std::cos(el));
          const Eigen::Vector3d hit = u * (z / u.z());
          const Eigen::Vector3d in_board = o.T_camera_board.inverse() * hit;
          const bool on_board = std::fabs(in_board.x()) <= 0.3 && std::fabs(in_board.y()) <= 0.3;
          const double outwards = board == 0 ? in_board.x() : -in_board.x();
          const bool clutter =
              beside && outwards > 0.5 && outwards < 0.55 && std::fabs(in_board.y()) <= 0.3;
          if (!on_board && !clutter) continue;
          const double range = hit.norm() + offset_m + noise(rng);
          points.push_back((range * u).cast<float>());
        }
      EXPECT_TRUE(set.Add(o, points.data(), nullptr, static_cast<int>(points.size())));
    }
  }
  return set;
}

std::vector<BoardGeometry> Boards() {
  BoardGeometry g;
  g.width_m = g.height_m = 0.6;
  return {g, g};
}

TEST(RangeOffsetTest, BoardsLeftAndRightOfADriveMeasureIt) {
  const std::vector<BoardGeometry> boards = Boards();
  for (const double offset_m : {0.0, 0.03, -0.03}) {
    const ObservationSet set = Drive(offset_m, false);
    const RangeOffsetFit fit = FitRangeOffset(BoardDistances(set, Pose::Identity(), &boards),
                                              /*timed=*/false, /*min_cluster_blocks=*/8);
    ASSERT_TRUE(fit.fitted);
    EXPECT_NEAR(fit.offset_m, offset_m, 0.005) << "sigma " << fit.sigma_m;
    EXPECT_LT(fit.sigma_m, 0.005);
    EXPECT_NEAR(fit.offset_m, offset_m, 3.0 * fit.sigma_m + 0.002);
  }
}

TEST(RangeOffsetTest, PointsBesideABoardDoNotMoveIt) {
  const std::vector<BoardGeometry> boards = Boards();
  const ObservationSet set = Drive(0.03, true);
  const RangeOffsetFit fit =
      FitRangeOffset(BoardDistances(set, Pose::Identity(), &boards), false, 8);
  ASSERT_TRUE(fit.fitted);
  EXPECT_NEAR(fit.offset_m, 0.03, 0.005) << "sigma " << fit.sigma_m;
  // Without the outlines, the points beside the boards pull the centres outwards, as a longer
  // range would.
  const RangeOffsetFit pulled = FitRangeOffset(BoardDistances(set, Pose::Identity()), false, 8);
  ASSERT_TRUE(pulled.fitted);
  EXPECT_GT(std::fabs(pulled.offset_m - 0.03), 0.01) << pulled.offset_m;
}

TEST(RangeOffsetTest, TooFewRowsAreNotFitted) { EXPECT_FALSE(FitRangeOffset({}, false, 8).fitted); }

}  // namespace
}  // namespace calibd
