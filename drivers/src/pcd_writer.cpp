#include "calibd/drivers/pcd_writer.hpp"

#include <cstring>
#include <sstream>

namespace calibd {

namespace {

template <typename T>
void Append(std::string* out, T value) {
  char bytes[sizeof(T)];
  std::memcpy(bytes, &value, sizeof(T));  // PCD binary data is little-endian, as the host
  out->append(bytes, sizeof(T));
}

}  // namespace

std::string PcdBinaryFile(const lidar_frame_t& frame, bool with_ring) {
  const int n = frame.num_points;
  std::ostringstream header;
  header << "# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\n"
         << (with_ring ? "FIELDS x y z intensity ring t\nSIZE 4 4 4 4 2 4\nTYPE F F F F I F\n"
                         "COUNT 1 1 1 1 1 1\n"
                       : "FIELDS x y z intensity t\nSIZE 4 4 4 4 4\nTYPE F F F F F\n"
                         "COUNT 1 1 1 1 1\n")
         << "WIDTH " << n << "\nHEIGHT 1\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n
         << "\nDATA binary\n";
  std::string out = header.str();
  out.reserve(out.size() + static_cast<size_t>(n) * (with_ring ? 22 : 20));
  for (int i = 0; i < n; ++i) {
    Append(&out, frame.x[i]);
    Append(&out, frame.y[i]);
    Append(&out, frame.z[i]);
    Append(&out, static_cast<size_t>(i) < frame.intensity.size() ? frame.intensity[i] : 0.0f);
    if (with_ring) Append(&out, static_cast<int16_t>(frame.ring[i]));
    Append(&out, static_cast<size_t>(i) < frame.time_offset_us.size()
                     ? static_cast<float>(frame.time_offset_us[i] * 1e-6)
                     : 0.0f);
  }
  return out;
}

}  // namespace calibd
