// The camera-LiDAR distance rows and their weighted fit (board_distances.hpp): a board's distance
// along its normal from PnP and from its LiDAR points, what a LiDAR range offset does to it, the
// in-plane centre left by mixed returns off the plane, and the fit's two sigmas when rows of a
// block share their errors.

#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "calibd/core/session/board_distances.hpp"

namespace calibd {
namespace {

// One board 8 m ahead and 2 m to the right of a camera, turned 20 deg about its vertical axis;
// the LiDAR at the camera's origin (T_camera_lidar = identity). `range_offset_m` lengthens every
// LiDAR range.
ObservationSet OneBoard(double range_offset_m) {
  ObservationSet set;
  set.Reserve(1, 400);
  BoardObservation o;
  o.frame = 0;
  o.board_index = 0;
  o.T_camera_board.linear() =
      Eigen::AngleAxisd(20.0 * M_PI / 180.0, Eigen::Vector3d::UnitY()).toRotationMatrix() *
      Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitY()).toRotationMatrix();
  o.T_camera_board.translation() = Eigen::Vector3d(2.0, 0.0, 8.0);
  // A 48 px tag side at this distance.
  o.corners_px = {Eigen::Vector2d(0, 0), Eigen::Vector2d(48, 0), Eigen::Vector2d(48, 48),
                  Eigen::Vector2d(0, 48)};
  std::vector<Eigen::Vector3f> points;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j) {
      const Eigen::Vector3d p =
          o.T_camera_board * Eigen::Vector3d(-0.3 + 0.03 * i, -0.3 + 0.03 * j, 0.0);
      points.push_back((p + range_offset_m * p.normalized()).cast<float>());
    }
  EXPECT_TRUE(set.Add(o, points.data(), nullptr, static_cast<int>(points.size())));
  return set;
}

TEST(BoardDistancesTest, BothSensorsDistancesAlongTheNormalAndWhatARangeOffsetAddsToThem) {
  const std::vector<BoardDistance> clean = BoardDistances(OneBoard(0.0), Pose::Identity());
  ASSERT_EQ(clean.size(), 1u);
  const BoardDistance& b = clean[0];
  EXPECT_GT(b.camera_m, 0.0);
  EXPECT_NEAR(b.camera_m, Eigen::Vector3d(2.0, 0.0, 8.0).dot(b.normal), 1e-9);
  EXPECT_NEAR(b.lidar_m, b.camera_m, 1e-5);
  EXPECT_NEAR(b.mean_ray.norm(), 1.0, 1e-12);
  EXPECT_NEAR(b.weight, 48.0 / Eigen::Vector3d(2.0, 0.0, 8.0).norm(), 1e-9);
  // A range offset moves the LiDAR's plane by b (n . u), u the mean ray: a tenth of a millimetre
  // off over a board 0.6 m wide at 8 m.
  const std::vector<BoardDistance> longer = BoardDistances(OneBoard(0.05), Pose::Identity());
  ASSERT_EQ(longer.size(), 1u);
  EXPECT_NEAR(longer[0].lidar_m - b.camera_m, 0.05 * b.normal.dot(b.mean_ray), 2e-4);
  EXPECT_GT(longer[0].lidar_m, b.lidar_m + 0.04);
}

// Returns mixed from a board's edge and the wall behind it lie off the board's plane; along the
// slanted rays of a board turned 20 deg they land beside one edge only. The in-plane centre counts
// the points on the plane: 20 such returns beyond the right edge (within the outline's margin,
// 0.2-0.6 m behind the plane) leave it where it was.
TEST(BoardDistancesTest, MixedReturnsBehindAnEdgeLeaveTheInPlaneCentre) {
  BoardGeometry g;
  g.width_m = g.height_m = 0.6;
  const std::vector<BoardGeometry> boards = {g};
  const ObservationSet clean = OneBoard(0.0);
  ObservationSet mixed;
  mixed.Reserve(1, 420);
  std::vector<Eigen::Vector3f> points(clean.points.begin(),
                                      clean.points.begin() + clean.observations[0].num_points);
  for (int k = 0; k < 20; ++k) {
    const Eigen::Vector3d in_board(0.31 + 0.002 * k, -0.3 + 0.03 * k, -0.2 - 0.02 * k);
    points.push_back((clean.observations[0].T_camera_board * in_board).cast<float>());
  }
  ASSERT_TRUE(
      mixed.Add(clean.observations[0], points.data(), nullptr, static_cast<int>(points.size())));
  const std::vector<BoardDistance> a = BoardDistances(clean, Pose::Identity(), &boards);
  const std::vector<BoardDistance> b = BoardDistances(mixed, Pose::Identity(), &boards);
  ASSERT_EQ(a.size(), 1u);
  ASSERT_EQ(b.size(), 1u);
  EXPECT_NEAR(b[0].lidar_in_plane.x(), a[0].lidar_in_plane.x(), 1e-9);
  EXPECT_NEAR(b[0].lidar_in_plane.y(), a[0].lidar_in_plane.y(), 1e-9);
  EXPECT_NEAR(b[0].lidar_m, a[0].lidar_m, 0.01);  // the median plane: hardly moved
}

// y = 2 a0 - a1 over 40 blocks of 10 rows; each block shares one error of 0.1 and each row has
// its own of 0.01. The least-squares sigma sees only the scatter of the rows (as if they were
// 400 independent), the cluster-robust one the blocks (as if they were 40).
TEST(BoardDistancesTest, TheFitRecoversItsUnknownsAndItsSigmaCountsErrorsSharedWithinABlock) {
  std::mt19937 rng(7);
  std::normal_distribution<double> shared(0.0, 0.1), own(0.0, 0.01), spread(0.0, 1.0);
  DistanceFitter fitter(2);
  for (int block = 0; block < 40; ++block) {
    BoardObservation o;
    o.board_index = 0;
    const double e = shared(rng);
    for (int k = 0; k < kDistanceBlockFrames; ++k) {
      o.frame = block * kDistanceBlockFrames + k;
      const Eigen::Vector2d a(1.0 + 0.1 * spread(rng), spread(rng));
      fitter.Add(o, a, 2.0 * a(0) - a(1) + e + own(rng));
    }
  }
  const DistanceFit fit = fitter.Fit();
  ASSERT_TRUE(fit.fitted);
  EXPECT_EQ(fit.rows, 400);
  EXPECT_EQ(fit.blocks, 40);
  const double ls = std::sqrt(fit.cov_ls(0, 0)), cluster = std::sqrt(fit.cov_cluster(0, 0));
  EXPECT_GT(cluster, 2.0 * ls) << "least squares " << ls << ", cluster-robust " << cluster;
  EXPECT_EQ(fit.Sigma(0, 8), cluster);
  EXPECT_EQ(fit.Sigma(0, 41), ls);
  EXPECT_NEAR(fit.x(0), 2.0, 4.0 * cluster);
  EXPECT_NEAR(fit.x(1), -1.0, 4.0 * std::sqrt(fit.cov_cluster(1, 1)));
  // As many rows as unknowns, or a column of zeros: not fitted.
  DistanceFitter few(2);
  few.Add(BoardObservation{}, Eigen::Vector2d(1.0, 0.0), 1.0);
  few.Add(BoardObservation{}, Eigen::Vector2d(0.0, 1.0), 1.0);
  EXPECT_FALSE(few.Fit().fitted);
  DistanceFitter singular(2);
  for (int k = 0; k < 5; ++k) singular.Add(BoardObservation{}, Eigen::Vector2d(k, 0.0), k);
  EXPECT_FALSE(singular.Fit().fitted);
}

}  // namespace
}  // namespace calibd
