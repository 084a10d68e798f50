// RangeImage (paper §III-C-1): ring and ringless cells, nearest point kept and nearby ones
// chained, invalid points.

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/lidar/range_image.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <vector>

namespace calibd {
namespace {

struct Cloud {
  std::vector<float> x, y, z;
  std::vector<int16_t> ring;
  void Add(double range, double az_deg, double el_deg, int r = -1) {
    x.push_back(
        static_cast<float>(range * std::cos(el_deg * kDeg2Rad) * std::cos(az_deg * kDeg2Rad)));
    y.push_back(
        static_cast<float>(range * std::cos(el_deg * kDeg2Rad) * std::sin(az_deg * kDeg2Rad)));
    z.push_back(static_cast<float>(range * std::sin(el_deg * kDeg2Rad)));
    ring.push_back(static_cast<int16_t>(r));
  }
  PointCloudView View(bool with_rings) const {
    PointCloudView v;
    v.x = x.data();
    v.y = y.data();
    v.z = z.data();
    v.ring = with_rings ? ring.data() : nullptr;
    v.size = x.size();
    return v;
  }
};

TEST(RangeImageTest, RingLidarRowsFollowElevationAndColumnsTheFiringAngles) {
  const LidarModel model = MakeLidarModel(LidarKind::kOt128);
  RangeImage image;
  image.Configure(model, 1.0, 60.0, 1000);
  ASSERT_EQ(image.rows(), 128);
  ASSERT_EQ(image.cols(), 1800);
  EXPECT_TRUE(image.wraps());
  Cloud c;
  c.Add(10.0, 0.0, model.ring_elevation_deg[0], 0);       // top ring, straight ahead
  c.Add(12.0, 90.0, model.ring_elevation_deg[127], 127);  // bottom ring, to the left
  c.Add(8.0, -179.95, model.ring_elevation_deg[41], 41);  // just past the seam
  RangeImageStats stats;
  image.Build(c.View(true), &stats);
  EXPECT_EQ(stats.invalid_points, 0);
  EXPECT_EQ(image.cell(127, 900).index, 0);  // (0 + 180.1) / 0.2 = 900.5
  EXPECT_NEAR(image.cell(127, 900).range, 10.0, 1e-4);
  EXPECT_EQ(image.cell(0, 1350).index, 1);  // (90 + 180.1) / 0.2 = 1350.5
  // Ring 41 is at 0.000 deg: its row counts the rings below it (86 are lower).
  EXPECT_EQ(image.cell(86, 0).index, 2);

  // Without ring numbers the row comes from the elevation: same cells.
  RangeImage no_rings;
  no_rings.Configure(model, 1.0, 60.0, 1000);
  no_rings.Build(c.View(false), &stats);
  EXPECT_EQ(no_rings.cell(127, 900).index, 0);
  EXPECT_EQ(no_rings.cell(0, 1350).index, 1);
  EXPECT_EQ(no_rings.cell(86, 0).index, 2);
}

TEST(RangeImageTest, RinglessLidarBinsAtItsResolutionAndKeepsTheNearestPoint) {
  const LidarModel model = MakeLidarModel(LidarKind::kM1);
  RangeImage image;
  image.Configure(model, 1.0, 60.0, 1000);
  ASSERT_EQ(image.cols(), 600);  // 120 deg / 0.2 deg
  ASSERT_EQ(image.rows(), 125);  // 25 deg / 0.2 deg
  EXPECT_FALSE(image.wraps());
  Cloud c;
  c.Add(20.0, 10.1, 2.15);  // bin (floor(14.65 / 0.2), floor(70.1 / 0.2)) = (73, 350)
  c.Add(7.0, 10.15, 2.18);  // same bin, nearer: kept
  c.Add(9.0, 10.12, 2.12);  // same bin, farther than the kept one: dropped
  c.Add(10.0, 150.0, 0.0);  // behind the sensor: outside the field of view
  RangeImageStats stats;
  image.Build(c.View(false), &stats);
  EXPECT_EQ(image.cell(73, 350).index, 1);
  EXPECT_NEAR(image.cell(73, 350).range, 7.0, 1e-4);
  EXPECT_EQ(stats.dropped_points, 2);
  EXPECT_EQ(stats.outside_points, 1);
  EXPECT_EQ(image.point_cell()[0], image.CellIndex(73, 350));
  EXPECT_EQ(image.point_cell()[3], -1);
  int row = 0, col = 0;
  ASSERT_TRUE(image.CellOf(10.1 * kDeg2Rad, 2.15 * kDeg2Rad, &row, &col));
  EXPECT_EQ(row, 73);
  EXPECT_EQ(col, 350);
}

TEST(RangeImageTest, FurtherPointsOfACellWithinTheToleranceAreChainedToIt) {
  const LidarModel model = MakeLidarModel(LidarKind::kM1);
  RangeImage image;
  image.Configure(model, 1.0, 60.0, 1000, 0.1);
  Cloud c;
  c.Add(20.05, 10.1, 2.15);   // bin (73, 350), within 0.1 m of the nearest: chained
  c.Add(20.0, 10.15, 2.18);   // the nearest: kept
  c.Add(21.0, 10.12, 2.12);   // 1 m behind (the wall past a board's edge): dropped
  c.Add(20.08, 10.18, 2.11);  // chained
  c.Add(20.0, 10.5, 2.15);    // the next bin: its own cell
  RangeImageStats stats;
  image.Build(c.View(false), &stats);
  const RangeImageCell& cell = image.cell(73, 350);
  EXPECT_EQ(cell.index, 1);
  EXPECT_EQ(cell.num_points, 3);
  EXPECT_EQ(stats.chained_points, 2);
  EXPECT_EQ(stats.dropped_points, 1);
  std::vector<int> chain;
  for (int32_t i = cell.next_point; i >= 0; i = image.next_point()[i]) chain.push_back(i);
  ASSERT_EQ(chain.size(), 2u);
  EXPECT_TRUE((chain[0] == 0 && chain[1] == 3) || (chain[0] == 3 && chain[1] == 0));
  EXPECT_EQ(image.cell(73, 352).num_points, 1);
  EXPECT_EQ(image.cell(73, 352).next_point, -1);

  // A second Build starts the chains afresh.
  Cloud d;
  d.Add(20.0, 10.15, 2.18);
  image.Build(d.View(false), &stats);
  EXPECT_EQ(image.cell(73, 350).num_points, 1);
  EXPECT_EQ(image.cell(73, 350).next_point, -1);
  EXPECT_EQ(stats.chained_points, 0);
}

TEST(RangeImageTest, SkipsNanInfAndOutOfRangePointsAndHandlesAnEmptyCloud) {
  const LidarModel model = MakeLidarModel(LidarKind::kFalcon);
  RangeImage image;
  image.Configure(model, 1.0, 60.0, 3);
  Cloud c;
  c.Add(10.0, 0.0, 0.0);
  c.x[0] = std::numeric_limits<float>::quiet_NaN();
  c.Add(10.0, 0.0, 0.0);
  c.y[1] = std::numeric_limits<float>::infinity();
  c.Add(0.5, 0.0, 0.0);    // nearer than min_range
  c.Add(100.0, 0.0, 0.0);  // beyond the point capacity of 3
  RangeImageStats stats;
  image.Build(c.View(false), &stats);
  EXPECT_EQ(stats.invalid_points, 3);
  EXPECT_EQ(stats.overflow_points, 1);
  for (int i = 0; i < image.rows() * image.cols(); ++i) ASSERT_LT(image.cell(i).index, 0);

  image.Build(PointCloudView{}, &stats);
  EXPECT_EQ(stats.invalid_points, 0);
  EXPECT_EQ(stats.overflow_points, 0);
}

TEST(RangeImageTest, ABoxReachingPastTheFieldOfViewIsClippedToIt) {
  // A VLP-16 (+-15 deg, 360 deg) and an Avia-like rosette (70.4 x 77.2 deg, not wrapping).
  for (const LidarKind kind : {LidarKind::kVlp16, LidarKind::kAvia}) {
    const LidarModel model = MakeLidarModel(kind);
    RangeImage image;
    image.Configure(model, 0.5, 200.0, 10);
    const double top = model.elevation_max_deg * kDeg2Rad;
    int r0 = 0, r1 = 0, c0 = 0, c1 = 0;
    // Inside: the same cells as CellOf gives for its corners.
    ASSERT_TRUE(image.CellBoxOf(-2 * kDeg2Rad, 2 * kDeg2Rad, -3 * kDeg2Rad, 3 * kDeg2Rad, &r0, &r1,
                                &c0, &c1));
    int row = 0, col = 0;
    ASSERT_TRUE(image.CellOf(-2 * kDeg2Rad, -3 * kDeg2Rad, &row, &col));
    EXPECT_EQ(r0, row);
    EXPECT_EQ(c0, col);
    ASSERT_TRUE(image.CellOf(2 * kDeg2Rad, 3 * kDeg2Rad, &row, &col));
    EXPECT_EQ(r1, row);
    EXPECT_EQ(c1, col);
    // A near board's box past the top edge: its rows up to the top row, none lost.
    ASSERT_TRUE(image.CellBoxOf(-2 * kDeg2Rad, 2 * kDeg2Rad, top - 5 * kDeg2Rad,
                                top + 10 * kDeg2Rad, &r0, &r1, &c0, &c1));
    EXPECT_EQ(r1, image.rows() - 1);
    EXPECT_LT(r0, r1);
    // Wholly above the field of view: no cells.
    EXPECT_FALSE(image.CellBoxOf(-2 * kDeg2Rad, 2 * kDeg2Rad, top + 5 * kDeg2Rad,
                                 top + 9 * kDeg2Rad, &r0, &r1, &c0, &c1));
    if (!image.wraps()) {
      // Past the side of a limited field of view: clipped to the last column.
      const double side = model.azimuth_max_deg * kDeg2Rad;
      ASSERT_TRUE(image.CellBoxOf(side - 3 * kDeg2Rad, side + 8 * kDeg2Rad, 0.0, kDeg2Rad, &r0, &r1,
                                  &c0, &c1));
      EXPECT_EQ(c1, image.cols() - 1);
      EXPECT_FALSE(image.CellBoxOf(side + 2 * kDeg2Rad, side + 8 * kDeg2Rad, 0.0, kDeg2Rad, &r0,
                                   &r1, &c0, &c1));
    }
  }
}

TEST(RangeImageTest, FastAtan2IsWithinTwoMicroradiansOfStdAtan2) {
  double worst = 0.0;
  for (int i = 0; i < 3600; ++i) {
    const double a = i * 0.1 * kDeg2Rad - M_PI;
    for (double r : {0.01, 1.0, 150.0}) {
      const float x = static_cast<float>(r * std::cos(a)), y = static_cast<float>(r * std::sin(a));
      double e = std::fabs(FastAtan2(y, x) - std::atan2(y, x));
      e = std::min(e, 2.0 * M_PI - e);  // +-pi are the same direction
      worst = std::max(worst, e);
    }
  }
  EXPECT_LT(worst, 2e-5);
}

}  // namespace
}  // namespace calibd
