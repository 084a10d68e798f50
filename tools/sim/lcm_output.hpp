#pragma once
/// \file
/// Converts simulated sensor data into calibd's LCM messages.

#include <opencv2/core.hpp>
#include <string>

#include "calibd/camera_frame_t.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "calibd/sensor_info_t.hpp"
#include "lidar_sim.hpp"

namespace calibd::sim {

/// mono8 image -> camera_frame_t, raw (ENCODING_MONO8) or compressed (ENCODING_JPEG at
/// `jpeg_quality`). Buffers of `msg` are reused. False if the JPEG encoder fails.
bool ToCameraMessage(const cv::Mat& mono8, int64_t utime, const std::string& camera_id,
                     int8_t encoding, int jpeg_quality, calibd::camera_frame_t* msg);

/// Sweep -> lidar_frame_t (struct of arrays; buffers of `msg` are reused).
void ToLidarMessage(const LidarScan& scan, int64_t utime, const std::string& lidar_id,
                    calibd::lidar_frame_t* msg);

}  // namespace calibd::sim
