#pragma once
/// \file
/// calibd-calibrate --debug DIR: what the detectors made of each frame pair, one JSON file per
/// pair (pair_000123.json), so that a user sees why a board was missed: every camera board with
/// its corners, PnP error and decision margin, the camera's rejected candidates, and every LiDAR
/// cluster of at least min_cluster_points with its figures and the gate that stopped it
/// (LidarDetectorConfig::report_clusters), and a picture of the range image with the clusters
/// coloured by that gate.

#include <cstdint>
#include <string>

#include "calibd/core/camera_detector.hpp"
#include "calibd/core/lidar_detector.hpp"

namespace calibd::tools {

struct FrameDebugInput {
  int pair_index = 0;
  int64_t camera_utime = 0, lidar_utime = 0;
  int lidar_points = 0;  ///< points in the sweep
  const CameraDetections* camera = nullptr;
  const LidarDetections* lidar = nullptr;
  /// The detector that made `lidar`, for the range-image picture (null: no picture).
  const LidarDetector* lidar_detector = nullptr;
};

/// The picture's colours, by what became of a cell (for --help and the JSON).
const char* FrameDebugPictureLegend();

/// The JSON text of one pair (also the file's contents).
std::string FrameDebugJson(const FrameDebugInput& in);

/// Writes DIR/pair_NNNNNN.json atomically and, with a detector, DIR/pair_NNNNNN.png: the range
/// image (top row the highest elevation, azimuth growing to the left as seen from the sensor),
/// each cell coloured by the gate that stopped its cluster (FrameDebugPictureLegend). False with
/// `error` naming the file.
bool WriteFrameDebug(const std::string& dir, const FrameDebugInput& in, std::string* error);

}  // namespace calibd::tools
