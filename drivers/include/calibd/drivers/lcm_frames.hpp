#pragma once
/// \file
/// The edge between LCM messages and core: checks a decoded camera or LiDAR message and exposes it
/// as a core view, or says exactly what is wrong with it. Nothing here trusts the sender: sizes
/// that lie, unknown encodings and absurd dimensions are refused.

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "calibd/camera_frame_t.hpp"
#include "calibd/core/common/image_view.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd {

struct FrameLimits {
  int max_width = 16384, max_height = 16384;  ///< pixels
  int max_points = 4000000;                   ///< per LiDAR frame
  /// A point's time_offset_us must lie within [-this, +this]: a sweep lasts 0.05-0.2 s, so
  /// larger offsets are a malformed message, not a slow sensor.
  int32_t max_time_offset_us = 1000000;
};

/// mono8 data is viewed in place (the message must outlive the view). JPEG is decoded to grey
/// (colour JPEGs too) and bgr8 converted to grey into `decoded`: into its top-left corner when it
/// is an 8-bit grey image at least as large as the frame (the view then has its row stride), else
/// into `decoded` (re)allocated at the frame's size; reused between calls, nothing is allocated
/// once it is large enough. JPEG is decoded with libjpeg-turbo by one decompressor per calling
/// thread, made by its first JPEG frame (libjpeg mallocs its working buffers for each image).
/// False with `error` naming the field when the message is malformed: sizes out of range or not
/// matching the data, a JPEG whose own header gives another size, damaged or truncated JPEG data
/// (libjpeg's warnings are errors here; the view is then unusable).
bool CameraFrameToView(const camera_frame_t& msg, const FrameLimits& limits, cv::Mat* decoded,
                       ImageView* view, std::string* error);

/// Views the struct-of-arrays in place. `ring` is null when every ring is -1 (no rings); the
/// per-point time offsets are always viewed (checked against the limits).
bool LidarFrameToView(const lidar_frame_t& msg, const FrameLimits& limits, PointCloudView* view,
                      std::string* error);

}  // namespace calibd
