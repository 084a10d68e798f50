#pragma once
/// \file
/// The one registry of LCM channels (name, type, nominal rate) used by the agent, the tools and the
/// tests. A rate of 0 marks an event-driven channel.

#include <array>
#include <string_view>

namespace calibd {

struct ChannelSpec {
  std::string_view name;  ///< LCM channel name
  std::string_view type;  ///< LCM type, package-qualified
  double rate_hz;         ///< nominal publish rate; 0 = on event
};

namespace channels {
inline constexpr ChannelSpec kCamera{"CALIBD_CAMERA", "calibd.camera_frame_t", 10.0};
inline constexpr ChannelSpec kLidar{"CALIBD_LIDAR", "calibd.lidar_frame_t", 10.0};
inline constexpr ChannelSpec kSensorInfo{"CALIBD_SENSOR_INFO", "calibd.sensor_info_t", 1.0};
inline constexpr ChannelSpec kRequest{"CALIBD_REQUEST", "calibd.calibration_request_t", 0.0};
inline constexpr ChannelSpec kStatus{"CALIBD_STATUS", "calibd.calibration_status_t", 2.0};
inline constexpr ChannelSpec kResult{"CALIBD_RESULT", "calibd.calibration_result_t", 0.0};
inline constexpr ChannelSpec kHealth{"CALIBD_HEALTH", "calibd.health_t", 1.0};

inline constexpr std::array<ChannelSpec, 7> kAll{kCamera, kLidar,  kSensorInfo, kRequest,
                                                 kStatus, kResult, kHealth};
}  // namespace channels

/// Looks a channel up by name; nullptr when the name is not in the registry.
constexpr const ChannelSpec* FindChannel(std::string_view name) {
  for (const auto& c : channels::kAll) {
    if (c.name == name) return &c;
  }
  return nullptr;
}

}  // namespace calibd
