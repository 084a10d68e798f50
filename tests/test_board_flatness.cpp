// Board bends measured from synthetic LiDAR points on flat and bent boards.

#include "calibd/core/verdict/board_flatness.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace calibd {
namespace {

struct Bend {
  double u = 0.0, v = 0.0;  // height at the vertical / horizontal centre line, m
};

// `frames` observations of one 0.9 m board at 3-8 m, turned up to 30 deg, each with `points`
// points on its face bent by `bend`, ranges noisy by `noise_m` (along the board's normal).
ObservationSet BentBoard(const BoardGeometry& g, const Pose& T_camera_lidar, Bend bend, int frames,
                         int points, double noise_m, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::normal_distribution<double> n01(0.0, 1.0);
  ObservationSet set;
  set.Reserve(frames, frames * points);
  std::vector<Eigen::Vector3f> pts(static_cast<size_t>(points));
  for (int f = 0; f < frames; ++f) {
    BoardObservation o;
    o.frame = f;
    o.board_index = 0;
    o.T_camera_board.linear() =
        RotationFromRpy(M_PI + 0.5 * unit(rng), 0.5 * unit(rng), 0.3 * unit(rng));
    o.T_camera_board.translation() =
        Eigen::Vector3d(unit(rng), 0.5 * unit(rng), 5.5 + 2.5 * unit(rng));
    const Pose T_lidar_board = T_camera_lidar.inverse() * o.T_camera_board;
    for (Eigen::Vector3f& p : pts) {
      const double u = unit(rng), v = unit(rng);
      const double z = bend.u * (1.0 - u * u) + bend.v * (1.0 - v * v) + noise_m * n01(rng);
      p = (T_lidar_board * Eigen::Vector3d(u * g.width_m / 2, v * g.height_m / 2, z)).cast<float>();
    }
    EXPECT_TRUE(set.Add(o, pts.data(), nullptr, points));
  }
  return set;
}

BoardGeometry Board() {
  BoardGeometry g;
  g.width_m = g.height_m = 0.9;
  g.tag_size_m = 0.702;
  return g;
}

Pose Extrinsic() {
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(-M_PI / 2, 0.0, -M_PI / 2);
  T.translation() = Eigen::Vector3d(0.1, -0.2, 0.05);
  return T;
}

TEST(BoardFlatnessTest, AFlatBoardMeasuresFlatWithinItsSigma) {
  const BoardGeometry g = Board();
  const ObservationSet set = BentBoard(g, Extrinsic(), {}, 40, 150, 0.01, 1);
  const std::vector<BoardBend> bends = EstimateBoardBends({g}, set, Extrinsic(), {});
  ASSERT_EQ(bends.size(), 1u);
  EXPECT_EQ(bends[0].observations, 40);
  EXPECT_LT(bends[0].sigma_u_m, 0.0015);
  EXPECT_LT(std::fabs(bends[0].bend_u_m), 3.0 * bends[0].sigma_u_m);
  EXPECT_LT(std::fabs(bends[0].bend_v_m), 3.0 * bends[0].sigma_v_m);
}

TEST(BoardFlatnessTest, BendsAboutEitherAxisAreMeasuredWithTheirSign) {
  const BoardGeometry g = Board();
  for (const Bend bend : {Bend{0.012, 0.0}, Bend{-0.008, 0.0}, Bend{0.0, 0.01}}) {
    const ObservationSet set = BentBoard(g, Extrinsic(), bend, 40, 150, 0.01, 2);
    const std::vector<BoardBend> b = EstimateBoardBends({g}, set, Extrinsic(), {});
    ASSERT_EQ(b.size(), 1u);
    EXPECT_NEAR(b[0].bend_u_m, bend.u, 3.0 * b[0].sigma_u_m) << bend.u << ", " << bend.v;
    EXPECT_NEAR(b[0].bend_v_m, bend.v, 3.0 * b[0].sigma_v_m) << bend.u << ", " << bend.v;
  }
}

TEST(BoardFlatnessTest, BoardPosesOffTheirPlaneDoNotLookLikeABend) {
  // Each observation's pose 2 cm off along the normal and turned 1 deg: taken up by the plane.
  const BoardGeometry g = Board();
  const ObservationSet set = BentBoard(g, Extrinsic(), {}, 40, 150, 0.005, 3);
  std::vector<Pose> poses;
  for (const BoardObservation& o : set.observations) {
    Pose T = o.T_camera_board;
    T.translation() += T.linear().col(2) * 0.02;
    T.linear() = T.linear() * RotationFromRpy(0.017, -0.017, 0.0);
    poses.push_back(T);
  }
  const std::vector<BoardBend> b = EstimateBoardBends({g}, set, Extrinsic(), poses);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_LT(std::fabs(b[0].bend_u_m), 0.001);
  EXPECT_LT(std::fabs(b[0].bend_v_m), 0.001);
}

TEST(BoardFlatnessTest, TooFewPointsMeasureNothing) {
  const BoardGeometry g = Board();
  const ObservationSet set = BentBoard(g, Extrinsic(), {0.02, 0.0}, 10, 12, 0.01, 4);
  EXPECT_TRUE(EstimateBoardBends({g}, set, Extrinsic(), {}).empty());
}

}  // namespace
}  // namespace calibd
