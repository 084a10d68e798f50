#pragma once
/// \file
/// --debug DIR (calibd-calibrate, and calibd-agent replaying a log): what the detectors made of
/// each frame pair, one JSON file per pair (pair_000123.json), so that a user sees why a board was
/// missed: every camera board with its corners, PnP error and decision margin, the camera's
/// rejected candidates, and every LiDAR cluster of at least min_cluster_points with its figures
/// and the gate that stopped it (LidarDetectorConfig::report_clusters); and a picture of the range
/// image with the clusters coloured by that gate (pair_000123.png).

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"

namespace calibd {

/// The range image of one sweep, each cell coloured by what became of its cluster
/// (FrameDebugPictureLegend); top row the highest elevation, azimuth growing to the left as seen
/// from the sensor. 8-bit RGB, rows packed.
struct RangeImagePicture {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
};

/// Draws `lidar` (with cluster reports) as `detector` made it: call it before the detector's next
/// Detect(), whose range image and labels it reads. Reuses `out`'s buffer.
void DrawRangeImagePicture(const LidarDetector& detector, const LidarDetections& lidar,
                           RangeImagePicture* out);

struct FrameDebugInput {
  int pair_index = 0;
  int64_t camera_utime = 0, lidar_utime = 0;
  int lidar_points = 0;  ///< points in the sweep
  const CameraDetections* camera = nullptr;
  const LidarDetections* lidar = nullptr;
  const RangeImagePicture* picture = nullptr;  ///< null: no picture
};

/// The picture's colours, by what became of a cell (for --help and the JSON).
const char* FrameDebugPictureLegend();

/// The JSON text of one pair (also the file's contents).
std::string FrameDebugJson(const FrameDebugInput& in);

/// Writes DIR/pair_NNNNNN.json atomically and, with a picture, DIR/pair_NNNNNN.png. False with
/// `error` naming the file.
bool WriteFrameDebug(const std::string& dir, const FrameDebugInput& in, std::string* error);

}  // namespace calibd
