#pragma once
// The CRC-32 (zlib's, ISO 3309) of a byte string: what the calibration store and the LiDAR
// reference cache check their files with.

#include <zlib.h>

#include <cstdint>
#include <string_view>

namespace calibd {

inline uint32_t Crc32(std::string_view bytes) {
  uLong crc = crc32_z(0L, Z_NULL, 0);
  crc = crc32_z(crc, reinterpret_cast<const Bytef*>(bytes.data()), bytes.size());
  return static_cast<uint32_t>(crc & 0xffffffffUL);
}

}  // namespace calibd
