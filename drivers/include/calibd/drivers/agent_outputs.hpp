#pragma once
/// \file
/// Reads back what calibd-agent published into an LCM log (`--publish-url file://...`): how many
/// status, result and health messages, the last of each, and the highest frame rates reported.
/// Used by the end-to-end tests and the memory benchmark to judge a run by its outputs.

#include <string>

#include "calibd/calibration_result_t.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/health_t.hpp"

namespace calibd {

struct AgentOutputs {
  int status = 0, health = 0, results = 0;  ///< messages decoded, per channel
  int undecodable = 0;                      ///< messages on those channels that did not decode
  calibration_status_t last_status{};
  calibration_result_t last_result{};
  health_t last_health{};
  float max_camera_rate_hz = 0.f, max_lidar_rate_hz = 0.f;  ///< over every health message
};

/// False with `error` naming the path when the log cannot be opened.
bool ReadAgentOutputs(const std::string& log_path, AgentOutputs* out, std::string* error);

}  // namespace calibd
