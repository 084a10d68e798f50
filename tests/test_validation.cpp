// The IsValid convention (core validation.hpp): one helper sets the error, and the range checks
// refuse NaN and infinities alike, in every config struct that uses them.

#include <gtest/gtest.h>

#include <limits>
#include <string>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/validation.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/solve/direct_optimizer.hpp"

namespace calibd {
namespace {

constexpr double kInf = std::numeric_limits<double>::infinity();
constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(ValidationTest, InvalidSetsTheErrorWhenGivenAndFiniteChecksRefuseNanAndInfinity) {
  std::string error;
  EXPECT_FALSE(Invalid(&error, "x must be > 0"));
  EXPECT_EQ(error, "x must be > 0");
  EXPECT_FALSE(Invalid(nullptr, "ignored"));
  EXPECT_TRUE(FiniteAbove(1.0, 0.0));
  EXPECT_FALSE(FiniteAbove(0.0, 0.0));
  EXPECT_FALSE(FiniteAbove(kInf, 0.0));
  EXPECT_FALSE(FiniteAbove(kNaN, 0.0));
  EXPECT_TRUE(FiniteAtLeast(0.0, 0.0));
  EXPECT_FALSE(FiniteAtLeast(kInf, 0.0));
  EXPECT_FALSE(FiniteAtLeast(kNaN, 0.0));
}

TEST(ValidationTest, ConfigsRefuseAnInfinityLikeANan) {
  for (const double bad : {kInf, kNaN}) {
    std::string error;
    MotionCompensationConfig motion;
    motion.max_speed_mps = bad;
    EXPECT_FALSE(motion.IsValid(&error));
    EXPECT_NE(error.find("max_speed_mps"), std::string::npos) << error;
    DirectOptimizerConfig direct;
    direct.corner_huber_px = bad;
    EXPECT_FALSE(direct.IsValid(&error));
    EXPECT_NE(error.find("corner_huber_px"), std::string::npos) << error;
    LidarDetectorConfig lidar;
    lidar.max_planarity = bad;
    EXPECT_FALSE(lidar.IsValid(&error));
    EXPECT_NE(error.find("max_planarity"), std::string::npos) << error;
    CameraIntrinsics camera;
    camera.width = 1920;
    camera.height = 1200;
    camera.fx = 1000.0;
    camera.fy = bad;
    camera.cx = 960.0;
    camera.cy = 600.0;
    EXPECT_FALSE(camera.IsValid(&error));
    EXPECT_NE(error.find("fx/fy"), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace calibd
