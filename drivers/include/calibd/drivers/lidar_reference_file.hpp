#pragma once
/// \file
/// The file that keeps a LiDAR detector's reference descriptors between the agent's starts
/// (core/lidar/reference_set.hpp). Binary, in this machine's byte order (a cache, never moved
/// between machines): the magic "CALIBDLR", the layout version, a byte-order mark, the set's key,
/// dims and count, the views (int32), the descriptors (float32), and a CRC-32 (zlib) of all that
/// precedes it. Written whole or not at all (atomic_file.hpp); read back whole and checked, so a
/// torn, truncated or foreign file is refused with the reason and the references are built again.

#include <string>
#include <string_view>

#include "calibd/core/lidar/reference_set.hpp"

namespace calibd {

std::string EncodeReferenceSet(const LidarReferenceSet& set);
/// False with `error` naming what is wrong (magic, version, byte order, sizes, CRC-32).
bool DecodeReferenceSet(std::string_view bytes, LidarReferenceSet* set, std::string* error);

/// Reads `path`; false with `error` (which names the path) when it is missing, unreadable or
/// malformed.
bool ReadReferenceFile(const std::string& path, LidarReferenceSet* set, std::string* error);
/// Writes `path` atomically, creating its directory when missing.
bool WriteReferenceFile(const std::string& path, const LidarReferenceSet& set, std::string* error);

}  // namespace calibd
