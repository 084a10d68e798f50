// core/geometry.hpp: roll/pitch/yaw round trips, at the gimbal lock too (pitch = +-90 deg, where
// a forward camera's T_camera_lidar sits).

#include "calibd/core/common/geometry.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

namespace calibd {
namespace {

double MaxDiff(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  return (a - b).cwiseAbs().maxCoeff();
}

TEST(GeometryTest, RpyRebuildsRandomRotations) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 1000; ++i) {
    const Eigen::Matrix3d R =
        Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    const Eigen::Vector3d rpy = RpyFromRotation(R);
    EXPECT_LE(std::abs(rpy.y()), M_PI / 2);
    EXPECT_LT(MaxDiff(RotationFromRpy(rpy.x(), rpy.y(), rpy.z()), R), 1e-12) << R;
  }
}

TEST(GeometryTest, RpyOfKnownAnglesComesBack) {
  const Eigen::Vector3d rpy =
      RpyFromRotation(RotationFromRpy(10 * kDeg2Rad, -20 * kDeg2Rad, 30 * kDeg2Rad));
  EXPECT_NEAR(rpy.x(), 10 * kDeg2Rad, 1e-12);
  EXPECT_NEAR(rpy.y(), -20 * kDeg2Rad, 1e-12);
  EXPECT_NEAR(rpy.z(), 30 * kDeg2Rad, 1e-12);
}

TEST(GeometryTest, RpyRebuildsRotationsAtAndNearTheGimbalLock) {
  Eigen::Matrix3d forward;  // calibd-sim's mechanical design: camera z = LiDAR x
  forward << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  for (const double off : {0.0, 1e-12, 1e-9, 1e-7, 1e-5, 1e-3}) {
    for (const Eigen::Vector3d& axis :
         {Eigen::Vector3d(1, 0, 0), Eigen::Vector3d(0, 1, 0), Eigen::Vector3d(0.3, -0.5, 0.8)}) {
      for (const Eigen::Matrix3d& base :
           {forward, Eigen::Matrix3d(RotationFromRpy(0.4, M_PI / 2, -1.1)),
            Eigen::Matrix3d(RotationFromRpy(-2.0, -M_PI / 2, 2.5))}) {
        const Eigen::Matrix3d R = base * RotationFromAxisAngle(axis, off);
        const Eigen::Vector3d rpy = RpyFromRotation(R);
        EXPECT_LT(MaxDiff(RotationFromRpy(rpy.x(), rpy.y(), rpy.z()), R), 1e-12)
            << "off " << off << "\n"
            << R << "\nrpy " << rpy.transpose();
      }
    }
  }
}

}  // namespace
}  // namespace calibd
