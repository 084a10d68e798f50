// MeasureBoardOutline on images rendered here: a board turned away from the camera, its tag
// printed centred, against a textured background. Configured with the tag off-centre, the
// board's edges must say by how much; configured right, by nothing; on a background as bright
// as the board, no edge is trusted.

#include <gtest/gtest.h>

#include <cmath>
#include <vector>

#include "calibd/core/camera/board_outline.hpp"
#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"

namespace calibd {
namespace {

constexpr int kWidth = 1280, kHeight = 960;

CameraIntrinsics Camera() {
  CameraIntrinsics c;
  c.width = kWidth;
  c.height = kHeight;
  c.fx = c.fy = 1000.0;
  c.cx = 639.5;
  c.cy = 479.5;
  c.k1 = c.k2 = c.k3 = c.p1 = c.p2 = 0.0;
  return c;
}

// The printed board at T_camera_board (its tag at the board's centre), 3 x 3 samples a pixel.
std::vector<uint8_t> Render(const BoardGeometry& printed, const Pose& T_camera_board,
                            double background_grey, double stripes_grey) {
  std::vector<uint8_t> image(static_cast<size_t>(kWidth * kHeight));
  const CameraIntrinsics c = Camera();
  const Pose T_board_camera = T_camera_board.inverse();
  const Eigen::Vector3d origin = T_board_camera.translation();
  for (int v = 0; v < kHeight; ++v)
    for (int u = 0; u < kWidth; ++u) {
      double sum = 0.0;
      for (int i = 0; i < 3; ++i)
        for (int j = 0; j < 3; ++j) {
          const Eigen::Vector3d ray_c((u + (i - 1) / 3.0 - c.cx) / c.fx,
                                      (v + (j - 1) / 3.0 - c.cy) / c.fy, 1.0);
          const Eigen::Vector3d ray = T_board_camera.linear() * ray_c;
          const double t = -origin.z() / ray.z();
          const Eigen::Vector3d p = origin + t * ray;
          // A background of stripes a few pixels wide: texture, but no straight edge along the
          // board's.
          double grey = background_grey + stripes_grey * std::sin(0.37 * u + 0.23 * v);
          if (t > 0.0 && std::fabs(p.x()) <= printed.width_m / 2 &&
              std::fabs(p.y()) <= printed.height_m / 2)
            grey = std::fabs(p.x()) <= printed.tag_size_m / 2 &&
                           std::fabs(p.y()) <= printed.tag_size_m / 2
                       ? 20.0
                       : 200.0;
          sum += grey;
        }
      image[static_cast<size_t>(v * kWidth + u)] = static_cast<uint8_t>(std::lround(sum / 9.0));
    }
  return image;
}

Pose PrintedPose() {
  // Facing the camera (z_B towards it), turned 25 deg about its vertical and 10 deg about x.
  return PoseFromXyzRpy(Eigen::Vector3d(0.3, -0.2, 3.0),
                        Eigen::Vector3d(M_PI + 10.0 * kDeg2Rad, 25.0 * kDeg2Rad, 0.0));
}

BoardOutline Measure(const BoardGeometry& configured, double background_grey,
                     double stripes_grey = 25.0) {
  BoardGeometry printed = configured;
  printed.tag_offset_m.setZero();
  const std::vector<uint8_t> image = Render(printed, PrintedPose(), background_grey, stripes_grey);
  const ImageView view{image.data(), kWidth, kHeight, kWidth};
  // The configured board's frame, as PnP of the tag puts it: the tag at tag_offset_m.
  Pose T_camera_board = PrintedPose();
  T_camera_board.translation() -=
      T_camera_board.linear() *
      Eigen::Vector3d(configured.tag_offset_m.x(), configured.tag_offset_m.y(), 0.0);
  return MeasureBoardOutline(view, CameraModel(Camera()), configured, T_camera_board);
}

TEST(BoardOutlineTest, ATagConfiguredOffCentreIsSeenAsTheBoardsCentreOffTheConfiguredOne) {
  BoardGeometry board;
  board.tag_offset_m = Eigen::Vector2d(0.03, -0.02);
  const BoardOutline o = Measure(board, 60.0);
  for (float e : o.edge_offset_m) EXPECT_TRUE(std::isfinite(e));
  // The board's centre is the tag's: 30 mm right and 20 mm down of the configured centre... as
  // seen from the configured centre, +0.03 and +0.02 the other way round.
  EXPECT_NEAR(o.CentreOffsetX(), 0.03, 0.002);
  EXPECT_NEAR(o.CentreOffsetY(), -0.02, 0.002);
  // The board's size is the configured one: the edges move apart by nothing.
  EXPECT_NEAR(o.edge_offset_m[0] + o.edge_offset_m[1], 0.0, 0.003);
  EXPECT_NEAR(o.edge_offset_m[2] + o.edge_offset_m[3], 0.0, 0.003);
}

TEST(BoardOutlineTest, ABoardAsConfiguredHasItsEdgesWhereTheConfigPutsThem) {
  const BoardOutline o = Measure(BoardGeometry{}, 60.0);
  for (float e : o.edge_offset_m) {
    ASSERT_TRUE(std::isfinite(e));
    EXPECT_NEAR(e, 0.0, 0.002);
  }
}

TEST(BoardOutlineTest, NoEdgeIsTrustedAgainstABackgroundAsBrightAsTheBoard) {
  // A plain wall a grey level darker than the board (a textured one shows the board's edge
  // where its texture begins).
  const BoardOutline o = Measure(BoardGeometry{}, 199.0, 0.0);
  for (float e : o.edge_offset_m) EXPECT_FALSE(std::isfinite(e)) << e;
}

}  // namespace
}  // namespace calibd
