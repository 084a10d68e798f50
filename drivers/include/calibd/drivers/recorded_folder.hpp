#pragma once
/// \file
/// A folder of recorded frames as a stream of calibd's camera and LiDAR messages, in the order
/// they would have arrived live (so the same frame pairing as for an LCM log applies):
///  - point clouds `*.pcd` (see pcd_reader.hpp) and images `*.png`, `*.jpg`, `*.jpeg`;
///  - with a `frames.csv` in the folder, its rows give every file's time (see kFramesCsvHelp);
///    files not listed are ignored;
///  - without it, clouds and images pair by name stem (`000123.pcd` + `000123.png`), in stem
///    order (numeric when both stems are numbers). The files carry no times: pair k is stamped
///    k x stem_spacing_us, camera and LiDAR at the same instant (calibd-calibrate turns motion
///    compensation off for them: it needs true times).

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/camera_frame_t.hpp"
#include "calibd/drivers/pcd_reader.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd {

/// The CSV's documented columns (for --help texts).
inline constexpr const char* kFramesCsvHelp =
    "frames.csv: a header line `time_us,sensor,file`, then one row per file: time_us the\n"
    "capture time in integer microseconds (LiDAR: sweep start; camera: mid-exposure; one clock\n"
    "for both), sensor `lidar` or `camera`, file relative to the folder. Frames pair by time as\n"
    "in an LCM log: the camera time must fall within the LiDAR sweep (+- the pair tolerance).";

struct RecordedFolderOptions {
  /// Pseudo time between stem pairs (no CSV), us.
  int64_t stem_spacing_us = 1000000;
  /// Duration of one LiDAR sweep, us: a sweep is delivered at its start time plus this, which
  /// orders it after the camera frames taken during it.
  int64_t sweep_us = 100000;
};

/// One file of the folder, to be loaded in turn.
struct RecordedEntry {
  enum class Sensor { kCamera, kLidar };
  Sensor sensor = Sensor::kCamera;
  int64_t utime = 0;  ///< capture time (LiDAR: sweep start), us
  std::string path;   ///< folder/file
};

struct RecordedFolder {
  std::vector<RecordedEntry> entries;  ///< in delivery order
  bool timed = false;                  ///< from frames.csv (else paired by stem)
  /// Stem pairing: clouds and images whose stem has no partner (not in `entries`).
  int unmatched_clouds = 0, unmatched_images = 0;
};

/// Lists `dir` (and reads its frames.csv when present). False with `error` naming the folder, or
/// the CSV line and column, when it cannot be read, a listed file does not exist, or no frame
/// is found.
bool ScanRecordedFolder(const std::string& dir, const RecordedFolderOptions& options,
                        RecordedFolder* folder, std::string* error);

/// Loads an image as a camera message: PNG (8 or 16 bit, grey or colour) is converted to mono8
/// (ENCODING_MONO8, stride = width); JPEG is kept as its file's bytes (ENCODING_JPEG) when
/// `keep_jpeg`, else converted to mono8 too. False with `error` naming the file when it cannot be
/// decoded.
bool LoadRecordedImage(const RecordedEntry& entry, const std::string& camera_id, bool keep_jpeg,
                       camera_frame_t* msg, std::string* error);

/// Loads a PCD as a LiDAR message (see ReadPcdFile); `info` may be null.
bool LoadRecordedCloud(const RecordedEntry& entry, const std::string& lidar_id, lidar_frame_t* msg,
                       PcdInfo* info, std::string* error);

}  // namespace calibd
