#pragma once
/// \file
/// Reads Point Cloud Library PCD files (header VERSION 0.7 or 0.6; DATA ascii, binary or
/// binary_compressed) into calibd's LiDAR frame layout (lidar_frame_t's struct of arrays, the
/// layout LidarFrameToView() hands to the LiDAR detector).
///
/// Fields: x, y, z are required (TYPE F, SIZE 4 or 8, COUNT 1). Optional, of any TYPE/SIZE, first
/// element when COUNT > 1:
///  - `intensity` -> lidar_frame_t::intensity (0 when absent);
///  - `ring` -> ring (int16; -1 when absent);
///  - the point time, the first of `time`, `t`, `timestamp` -> time_offset_us (0 when absent).
///    Floating-point times are seconds (Velodyne `time`, Hesai/Livox `timestamp`), integer times
///    nanoseconds (Ouster `t`). Times of more than 1000 s are absolute: they are made relative to
///    the earliest point, whose time PcdInfo::time_base_us keeps.
/// Other fields and padding fields `_` are skipped. Points with a non-finite x, y or z (organized
/// clouds mark missing returns with NaN) are dropped and counted. Multi-byte values are
/// little-endian, as PCL writes them on every platform calibd runs on.
///
/// Nothing in the file is trusted: every malformed input is refused with an error naming the
/// file, the header line or field, and what is wrong.

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/lidar_frame_t.hpp"

namespace calibd {

struct PcdReadOptions {
  /// A file announcing more points (WIDTH x HEIGHT) is refused before anything is allocated:
  /// 4 M is 16 sweeps of a 128-beam LiDAR, far beyond any real frame.
  int64_t max_points = 4000000;
  /// The header (everything up to the DATA line) must end within this many bytes.
  size_t max_header_bytes = 65536;
};

/// What the header said and what became of the points.
struct PcdInfo {
  std::string version;                        ///< "0.7" or "0.6"
  std::string data;                           ///< "ascii", "binary" or "binary_compressed"
  int64_t width = 0, height = 0, points = 0;  ///< from the header
  std::vector<std::string> fields;            ///< FIELDS in file order (padding `_` included)
  bool has_intensity = false, has_ring = false;
  std::string time_field;    ///< the field the time offsets came from; empty when none
  int64_t time_base_us = 0;  ///< absolute times only: the earliest point's time, else 0
  int64_t nan_dropped = 0;   ///< points with a non-finite x, y or z, not in the output
  /// Binary data: bytes after the last point, ignored as PCL ignores them (0 for none). Callers
  /// warn about them.
  int64_t trailing_bytes = 0;
};

/// Parses the bytes of a PCD file. `name` (the file's path) starts every error. Fills `cloud`'s
/// num_points and arrays; its utime and lidar_id are left to the caller. False with `error` on
/// any malformed input (then `cloud` is unspecified).
bool ParsePcd(const std::string& bytes, const std::string& name, const PcdReadOptions& options,
              lidar_frame_t* cloud, PcdInfo* info, std::string* error);

/// Reads and parses `path` (see ParsePcd).
bool ReadPcdFile(const std::string& path, const PcdReadOptions& options, lidar_frame_t* cloud,
                 PcdInfo* info, std::string* error);

}  // namespace calibd
