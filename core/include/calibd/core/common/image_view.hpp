#pragma once
/// \file
/// Non-owning views of sensor data handed to core: the agent and the tools convert their messages
/// into these at their edge, so core never sees LCM or files.

#include <cstddef>
#include <cstdint>

namespace calibd {

/// An 8-bit grey image (mono8), rows `stride` bytes apart.
struct ImageView {
  const uint8_t* data = nullptr;
  int width = 0;
  int height = 0;
  int stride = 0;  ///< bytes per row, >= width
};

/// One LiDAR sweep as a struct of arrays, in the LiDAR frame (metres). `ring` may be null for
/// sensors without rings. Points may be NaN/inf (dropped returns): detectors skip them.
struct PointCloudView {
  const float* x = nullptr;
  const float* y = nullptr;
  const float* z = nullptr;
  const int16_t* ring = nullptr;  ///< laser channel per point, or null; -1 entries mean none
  size_t size = 0;
  /// Firing time of each point after the sweep start (microseconds), or null when the sensor
  /// does not report it: then the whole sweep counts as fired at its start.
  const int32_t* time_offset_us = nullptr;
};

}  // namespace calibd
