#pragma once
/// \file
/// The LiDAR model a session is detected with: the built-in one of `lidar.model`, or for
/// `generic` the scan geometry estimated from the first LiDAR frames of the log
/// (core/lidar_resolution.hpp), the config's lidar.generic.* values overriding it.

#include <string>

#include "calibd/core/config.hpp"
#include "calibd/core/lidar_model.hpp"
#include "calibd/core/lidar_resolution.hpp"

namespace calibd::tools {

/// Fills `model`. For `generic` it reads the first lidar.generic.estimation_frames frames of
/// `config.lidar_id` in the LCM log at `log_path` (an empty path: no frames, the config must give
/// every value) into `estimate`. False with `error` when the log cannot be read or the geometry
/// cannot be estimated.
bool LidarModelForLog(const std::string& log_path, const CalibConfig& config, LidarModel* model,
                      LidarResolutionEstimate* estimate, std::string* error);

}  // namespace calibd::tools
