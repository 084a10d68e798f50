#include "calibd/channels.hpp"

#include <gtest/gtest.h>

#include <set>
#include <string>

#include "calibd/calibration_request_t.hpp"
#include "calibd/calibration_result_t.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/camera_frame_t.hpp"
#include "calibd/health_t.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "calibd/sensor_info_t.hpp"

namespace calibd {
namespace {

TEST(ChannelsTest, NamesAreUniqueAndFindable) {
  std::set<std::string_view> names;
  for (const auto& c : channels::kAll) {
    EXPECT_TRUE(names.insert(c.name).second) << c.name;
    EXPECT_EQ(FindChannel(c.name), &c);
    EXPECT_GE(c.rate_hz, 0.0);
  }
  EXPECT_EQ(FindChannel("NOPE"), nullptr);
}

// The registry's type names must be the generated types' own names, so a mismatch fails here.
template <typename Msg>
std::string TypeName() {
  return std::string("calibd.") + Msg::getTypeName();
}

TEST(ChannelsTest, TypesMatchTheGeneratedMessages) {
  EXPECT_EQ(channels::kCamera.type, TypeName<camera_frame_t>());
  EXPECT_EQ(channels::kLidar.type, TypeName<lidar_frame_t>());
  EXPECT_EQ(channels::kSensorInfo.type, TypeName<sensor_info_t>());
  EXPECT_EQ(channels::kRequest.type, TypeName<calibration_request_t>());
  EXPECT_EQ(channels::kStatus.type, TypeName<calibration_status_t>());
  EXPECT_EQ(channels::kResult.type, TypeName<calibration_result_t>());
  EXPECT_EQ(channels::kHealth.type, TypeName<health_t>());
}

TEST(ChannelsTest, LidarFrameRoundTripsThroughEncoding) {
  lidar_frame_t m;
  m.utime = 123;
  m.lidar_id = "roof";
  m.num_points = 2;
  m.x = {1.0f, 2.0f};
  m.y = {0.5f, -0.5f};
  m.z = {0.1f, 0.2f};
  m.intensity = {10.0f, 20.0f};
  m.ring = {-1, -1};
  m.time_offset_us = {0, 50000};
  std::vector<uint8_t> buf(static_cast<size_t>(m.getEncodedSize()));
  ASSERT_EQ(m.encode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  lidar_frame_t back;
  ASSERT_EQ(back.decode(buf.data(), 0, static_cast<int>(buf.size())), static_cast<int>(buf.size()));
  EXPECT_EQ(back.num_points, 2);
  EXPECT_EQ(back.time_offset_us[1], 50000);
  EXPECT_FLOAT_EQ(back.y[1], -0.5f);
  // A buffer that lies about its size is refused, not over-read.
  EXPECT_LT(back.decode(buf.data(), 0, static_cast<int>(buf.size()) - 3), 0);
}

}  // namespace
}  // namespace calibd
