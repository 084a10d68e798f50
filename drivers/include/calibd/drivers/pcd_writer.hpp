#pragma once
/// \file
/// A LiDAR frame as a PCD file (PCL's format, version 0.7, DATA binary), as PCL, Open3D and
/// calibd's own reader (pcd_reader.hpp) read it: fields x y z intensity (float32), ring (int16,
/// only when the frame has rings) and t (float32, seconds after the sweep start).

#include <string>

#include "calibd/lidar_frame_t.hpp"

namespace calibd {

/// The file's bytes. `with_ring`: write the ring field (a sensor with rings).
std::string PcdBinaryFile(const lidar_frame_t& frame, bool with_ring);

}  // namespace calibd
