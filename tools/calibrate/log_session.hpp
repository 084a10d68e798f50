#pragma once
/// \file
/// Reads a recorded session (an LCM log of calibd's camera and LiDAR channels), pairs camera and
/// LiDAR frames by time, runs both board detectors on every pair and records the observations.

#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "calibd/core/camera_detector.hpp"
#include "calibd/core/config.hpp"
#include "calibd/core/lidar_detector.hpp"
#include "calibd/core/session_observations.hpp"

namespace calibd::tools {

struct LogReadOptions {
  int max_frames = 2000;              ///< frame pairs kept (capacity of the session store)
  int64_t pair_tolerance_us = 20000;  ///< camera time may lie this far outside the LiDAR sweep
  CameraDetectorConfig camera;
  LidarDetectorConfig lidar;
  /// False: only pair frames and copy the `keep` pairs (no detection, `session` untouched), e.g.
  /// to fetch pictures after a calibration.
  bool detect = true;
};

struct LogReadStats {
  int camera_frames = 0, lidar_frames = 0, pairs = 0;
  int unpaired_camera = 0, unpaired_lidar = 0;  ///< dropped: no partner within the tolerance
  int bad_messages = 0;                         ///< undecodable or malformed, skipped
  std::string first_bad_message;                ///< what was wrong with the first one
  int frames_over_capacity = 0;
  /// Dropped: time not after the previous frame of the same sensor (duplicates included).
  int out_of_order = 0;
  std::vector<double> camera_ms, lidar_ms;  ///< detection time per pair
};

/// One frame pair's images and points, for pictures after the calibration.
struct FramePairData {
  int pair_index = -1;
  cv::Mat image;               ///< mono8
  std::vector<float> x, y, z;  ///< LiDAR points
};

/// Reads `log_path`. `progress(pairs)` is called every 20 pairs (may be empty). When `keep` lists
/// pair indices, those pairs' data are copied into `kept`. False with `error` when the log cannot
/// be read or the detectors cannot be built from the config.
bool ReadSessionLog(const std::string& log_path, const CalibConfig& config,
                    const LogReadOptions& options, SessionObservations* session,
                    LogReadStats* stats, std::string* error,
                    const std::function<void(int)>& progress = {},
                    const std::vector<int>& keep = {}, std::vector<FramePairData>* kept = nullptr);

}  // namespace calibd::tools
