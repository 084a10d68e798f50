#pragma once
// Test helpers for the agent's end-to-end tests: the ground truth written by calibd-sim --truth
// and the messages the agent published into a file:// log (--publish-url).

#include <gtest/gtest.h>

#include <algorithm>
#include <lcm/lcm-cpp.hpp>
#include <nlohmann/json.hpp>
#include <string>

#include "calibd/calibration_result_t.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/geometry.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/health_t.hpp"

namespace calibd::testing {

/// The true T_camera_lidar of a calibd-sim truth file.
inline Pose TruthExtrinsic(const std::string& path) {
  std::string text, error;
  EXPECT_TRUE(ReadWholeFile(path, &text, &error)) << error;
  const auto j = nlohmann::json::parse(text);
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = j["T_camera_lidar"][r][c].get<double>();
  return T;
}

/// What the agent published: counts and the last message of each kind.
struct Published {
  int status = 0, health = 0, results = 0;
  calibration_status_t last_status;
  calibration_result_t last_result;
  health_t last_health;
  float max_camera_rate_hz = 0.f, max_lidar_rate_hz = 0.f;  ///< over every health message
};

inline Published ReadPublished(const std::string& path) {
  Published p;
  lcm::LogFile log(path, "r");
  EXPECT_TRUE(log.good()) << path;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    const int size = static_cast<int>(ev->datalen);
    if (ev->channel == channels::kStatus.name) {
      EXPECT_EQ(p.last_status.decode(ev->data, 0, size), size);
      ++p.status;
    } else if (ev->channel == channels::kResult.name) {
      EXPECT_EQ(p.last_result.decode(ev->data, 0, size), size);
      ++p.results;
    } else if (ev->channel == channels::kHealth.name) {
      EXPECT_EQ(p.last_health.decode(ev->data, 0, size), size);
      p.max_camera_rate_hz = std::max(p.max_camera_rate_hz, p.last_health.camera_rate_hz);
      p.max_lidar_rate_hz = std::max(p.max_lidar_rate_hz, p.last_health.lidar_rate_hz);
      ++p.health;
    }
  }
  return p;
}

}  // namespace calibd::testing
