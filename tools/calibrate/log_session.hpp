#pragma once
/// \file
/// Reads a recorded session (an LCM log of calibd's camera and LiDAR channels, or a folder of PCD
/// clouds and images, see calibd/drivers/recorded_folder.hpp), pairs camera and LiDAR frames by
/// time, runs both board detectors on every pair and records the observations.

#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/core/session/session_observations.hpp"

namespace calibd::tools {

struct LogReadOptions {
  int max_frames = 2000;              ///< frame pairs kept (capacity of the session store)
  int64_t pair_tolerance_us = 20000;  ///< camera time may lie this far outside the LiDAR sweep
  CameraDetectorConfig camera;
  LidarDetectorConfig lidar;
  /// The LiDAR model to detect with instead of the config's lidar.model (LidarModelForSession(): a
  /// generic model resolved from the first frames).
  std::optional<LidarModel> lidar_model;
  /// False: only pair frames and copy the `keep` pairs (no detection, `session` untouched), e.g.
  /// to fetch pictures after a calibration.
  bool detect = true;
  /// --debug: a directory (existing) receiving what the detectors made of each pair
  /// (calibd/drivers/frame_debug.hpp); empty: none. Turns on the LiDAR's cluster reports.
  std::string debug_dir;
};

struct LogReadStats {
  int camera_frames = 0, lidar_frames = 0, pairs = 0;
  int unpaired_camera = 0, unpaired_lidar = 0;  ///< dropped: no partner within the tolerance
  int bad_messages = 0;                         ///< undecodable or malformed, skipped
  std::string first_bad_message;                ///< what was wrong with the first one
  int bad_camera = 0, bad_lidar = 0;            ///< of them, per sensor
  std::string first_bad_camera, first_bad_lidar;
  int frames_over_capacity = 0;
  int debug_write_failures = 0;  ///< --debug files that could not be written
  std::string first_debug_error;
  /// Dropped: time not after the previous frame of the same sensor (duplicates included).
  int out_of_order = 0;
  std::vector<double> camera_ms, lidar_ms;  ///< detection time per pair
  /// Folder only: points with a non-finite x, y or z dropped from the clouds (organized PCDs),
  /// and files whose stem has no partner (no frames.csv).
  int64_t nan_points_dropped = 0;
  int unmatched_clouds = 0, unmatched_images = 0;
  bool pseudo_times = false;  ///< a folder paired by name stem: its times are made up
  /// Folder only: binary PCDs with bytes after their last point (read as PCL reads them), and the
  /// first of them.
  int padded_clouds = 0;
  std::string first_padded_cloud;
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

/// Why a session read from a log (`folder` false) or a folder gave no frame pair, in words a user
/// can act on (no frames at all, none of one sensor, all of one sensor malformed with the first
/// error, or frames that never paired); empty when it gave some. `lidar` is set when the LiDAR's
/// frames are the cause.
std::string NoPairsCause(const LogReadStats& stats, const CalibConfig& config, bool folder,
                         bool* lidar);

/// As ReadSessionLog, from a folder of recorded frames (ScanRecordedFolder): its frames go
/// through the same pairing and detection as a log's, messages given the config's camera and
/// LiDAR ids. A file that cannot be read or is malformed counts as a bad message (the first one's
/// error, naming the file, in `first_bad_message`), as a malformed log message does. False with
/// `error` when the folder cannot be listed or its frames.csv is malformed.
bool ReadSessionFolder(const std::string& folder_path, const CalibConfig& config,
                       const LogReadOptions& options, SessionObservations* session,
                       LogReadStats* stats, std::string* error,
                       const std::function<void(int)>& progress = {},
                       const std::vector<int>& keep = {},
                       std::vector<FramePairData>* kept = nullptr);

}  // namespace calibd::tools
