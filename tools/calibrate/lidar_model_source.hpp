#pragma once
/// \file
/// The LiDAR model a session is detected with: the built-in one of `lidar.model`, or for
/// `generic` the scan geometry estimated from the session's first LiDAR frames, from an LCM log
/// or a recorded folder (core/lidar_resolution.hpp), the config's lidar.generic.* values
/// overriding it.

#include <string>

#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "calibd/core/session/config.hpp"

namespace calibd::tools {

/// Where the session's frames come from: an LCM log or a recorded folder (one of the two; both
/// empty: no frames, the config must then give every lidar.generic value).
struct SessionSource {
  std::string log_path;
  std::string folder_path;
};

/// Fills `model`. For `generic` it reads the first lidar.generic.estimation_frames frames of
/// `config.lidar_id` from `source` into `estimate`. False with `error` when the source cannot be
/// read or the geometry cannot be estimated.
bool LidarModelForSession(const SessionSource& source, const CalibConfig& config, LidarModel* model,
                          LidarResolutionEstimate* estimate, std::string* error);

}  // namespace calibd::tools
