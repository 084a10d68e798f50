// CameraModel: projection, undistortion and the fold-over gate (docs/conventions.md#fold-over),
// for the radial-tangential and the Kannala-Brandt models.

#include <gtest/gtest.h>

#include <limits>

#include <cmath>
#include <opencv2/calib3d.hpp>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/geometry.hpp"

namespace calibd {
namespace {

// Unprojects a 49 x 25 grid over the whole image, projects the rays back at `depth` and checks
// every pixel comes back within 1e-6 px.
void ExpectRoundTripOverTheWholeImage(const CameraIntrinsics& c, double depth) {
  const CameraModel model(c);
  double worst = 0.0;
  for (double v = 0.0; v <= c.height - 1; v += (c.height - 1) / 24.0) {
    for (double u = 0.0; u <= c.width - 1; u += (c.width - 1) / 48.0) {
      const Eigen::Vector2d uv(u, v);
      Eigen::Vector2d xy;
      ASSERT_TRUE(model.Unproject(uv, &xy)) << "u=" << u << " v=" << v;
      Eigen::Vector2d back;
      ASSERT_TRUE(model.Project(Eigen::Vector3d(xy.x(), xy.y(), 1.0) * depth, &back))
          << "u=" << u << " v=" << v;
      worst = std::max(worst, (back - uv).norm());
    }
  }
  EXPECT_LT(worst, 1e-6);
}

TEST(CameraModel, UnprojectProjectRoundTripOverTheWholeImage) {
  ExpectRoundTripOverTheWholeImage(CameraIntrinsics{}, 7.0);  // defaults, with distortion
}

TEST(CameraModel, DistortToPixelMatchesOpenCvProjectPoints) {
  const CameraIntrinsics c;
  const CameraModel model(c);
  const cv::Matx33d K(c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0);
  const std::vector<double> dist{c.k1, c.k2, c.p1, c.p2, c.k3};  // OpenCV order
  std::vector<cv::Point3d> points;
  for (double y = -0.35; y <= 0.35; y += 0.05) {
    for (double x = -0.7; x <= 0.7; x += 0.05) points.emplace_back(x, y, 1.0);
  }
  std::vector<cv::Point2d> uv_cv;
  cv::projectPoints(points, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, dist, uv_cv);
  ASSERT_EQ(uv_cv.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d uv = model.DistortToPixel({points[i].x, points[i].y});
    EXPECT_NEAR(uv.x(), uv_cv[i].x, 1e-6) << "point " << i;
    EXPECT_NEAR(uv.y(), uv_cv[i].y, 1e-6) << "point " << i;
  }
}

TEST(CameraModel, FoldOverGateRejectsFarOffAxisPointsThatDistortIntoTheImage) {
  // With the default k3 < 0 the radial map turns back and crosses zero near 70 degrees off-axis
  // (docs/conventions.md#fold-over): a 360-degree LiDAR point there distorts *into* the image.
  const CameraIntrinsics c;
  ASSERT_LT(c.k3, 0.0);
  const CameraModel model(c);
  int folded_inside = 0;
  for (double deg = 60.0; deg < 89.5; deg += 0.25) {
    // Slightly above the horizontal meridian, on the right of the optical axis.
    const double r = std::tan(deg * kDeg2Rad);
    const Eigen::Vector2d xy(r * std::cos(0.02), r * std::sin(0.02));
    const Eigen::Vector2d naive = model.DistortToPixel(xy);
    const bool naive_inside =
        naive.x() >= 0 && naive.x() <= c.width - 1 && naive.y() >= 0 && naive.y() <= c.height - 1;
    if (!naive_inside) continue;
    ++folded_inside;
    Eigen::Vector2d uv;
    EXPECT_FALSE(model.Project(Eigen::Vector3d(xy.x(), xy.y(), 1.0) * 5.0, &uv))
        << deg << " deg off-axis lands naively at " << naive.transpose();
  }
  // The test is only meaningful if the fold-over really happens with these coefficients.
  EXPECT_GT(folded_inside, 0);
  // And the gate still admits everything that truly images, up to the image corners' rays.
  Eigen::Vector2d corner_xy;
  ASSERT_TRUE(model.Unproject({0.0, 0.0}, &corner_xy));
  EXPECT_GT(model.max_undistorted_radius(), corner_xy.norm());
}

TEST(CameraModel, RejectsPointsBehindTheCamera) {
  const CameraModel model{CameraIntrinsics{}};
  Eigen::Vector2d uv;
  EXPECT_FALSE(model.Project({0.0, 0.0, -5.0}, &uv));
  EXPECT_FALSE(model.Project({0.1, -0.05, -1.0}, &uv));  // would land near the centre if mirrored
  EXPECT_FALSE(model.Project({1.0, 0.0, 0.0}, &uv));
  EXPECT_TRUE(model.Project({0.1, -0.05, 1.0}, &uv));
}

TEST(CameraModel, IsValidNamesTheBadField) {
  CameraIntrinsics c;
  std::string error;
  EXPECT_TRUE(c.IsValid(&error));
  c.fx = 0.0;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("fx"), std::string::npos) << error;
  c.fx = -3325.0;
  error.clear();
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("fx"), std::string::npos) << error;
  // Infinite focal lengths (a config's `fx: +.INF`, found by fuzz_calib_config: it passed, and
  // the config written back did not parse).
  c.fx = 3325.0;
  c.fy = std::numeric_limits<double>::infinity();
  error.clear();
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("finite"), std::string::npos) << error;
}

// ---- Kannala-Brandt (equidistant fisheye, cv::fisheye's k1..k4) ----

CameraIntrinsics Fisheye() {
  CameraIntrinsics c;
  c.model = DistortionModel::kKannalaBrandt;
  c.width = 1920;
  c.height = 1080;
  c.fx = c.fy = 700.0;
  c.cx = 959.5;
  c.cy = 539.5;
  c.k1 = 0.03;
  c.k2 = -0.01;
  c.k3 = 0.004;
  c.k4 = -0.001;
  c.p1 = c.p2 = 0.0;
  return c;
}

TEST(CameraModel, KannalaBrandtMatchesOpenCvFisheyeProjectPoints) {
  const CameraIntrinsics c = Fisheye();
  const CameraModel model(c);
  const cv::Matx33d K(c.fx, 0.0, c.cx, 0.0, c.fy, c.cy, 0.0, 0.0, 1.0);
  const cv::Vec4d D(c.k1, c.k2, c.k3, c.k4);
  std::vector<cv::Point3d> points;
  for (double y = -1.5; y <= 1.5; y += 0.1) {
    for (double x = -2.5; x <= 2.5; x += 0.1) points.emplace_back(x, y, 1.0);
  }
  points.emplace_back(0.0, 0.0, 1.0);
  std::vector<cv::Point2d> uv_cv;
  cv::fisheye::projectPoints(points, uv_cv, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), K, D);
  ASSERT_EQ(uv_cv.size(), points.size());
  for (size_t i = 0; i < points.size(); ++i) {
    const Eigen::Vector2d uv = model.DistortToPixel({points[i].x, points[i].y});
    EXPECT_NEAR(uv.x(), uv_cv[i].x, 1e-6) << "point " << i;
    EXPECT_NEAR(uv.y(), uv_cv[i].y, 1e-6) << "point " << i;
  }
}

TEST(CameraModel, KannalaBrandtUnprojectProjectRoundTrip) {
  ExpectRoundTripOverTheWholeImage(Fisheye(), 3.0);
}

TEST(CameraModel, KannalaBrandtGateStopsWhereThetaDStopsIncreasing) {
  CameraIntrinsics c = Fisheye();
  // A negative k2 makes theta_d(theta) turn back before 90 deg off-axis.
  c.k1 = 0.0;
  c.k2 = -0.2;
  c.k3 = c.k4 = 0.0;
  const CameraModel model(c);
  const double max_theta = std::atan(model.max_undistorted_radius());
  // d theta_d / d theta = 1 + 5 k2 theta^4 reaches 0.05 at theta = (0.95 / 1) ^ (1/4).
  EXPECT_NEAR(max_theta, std::pow(0.95, 0.25), 2e-3);
  Eigen::Vector2d uv;
  const double beyond = std::tan(max_theta + 0.05);
  EXPECT_FALSE(model.Project({beyond, 0.0, 1.0}, &uv, 1e6));
  // Without fold-over the gate sits just below 90 deg; z <= 0 is always rejected.
  const CameraModel wide(Fisheye());
  EXPECT_GT(std::atan(wide.max_undistorted_radius()) * 180.0 / M_PI, 89.0);
  EXPECT_FALSE(wide.Project({1.0, 0.0, -0.01}, &uv, 1e6));
}

TEST(CameraModel, IsValidRejectsCoefficientsOfTheOtherModel) {
  CameraIntrinsics c = Fisheye();
  std::string error;
  EXPECT_TRUE(c.IsValid(&error)) << error;
  c.p1 = 0.001;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("p1"), std::string::npos) << error;
  CameraIntrinsics r;
  r.k4 = 0.01;
  EXPECT_FALSE(r.IsValid(&error));
  EXPECT_NE(error.find("k4"), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
