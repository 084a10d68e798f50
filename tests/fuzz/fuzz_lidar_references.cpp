// The agent's LiDAR reference cache file (drivers/lidar_reference_file.hpp) as it reads it at
// start-up: DecodeReferenceSet on the file's bytes (ReadReferenceFile reads the file, then calls
// it). Whatever it accepts has the shape it promises and encodes back to the same bytes.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/lidar_reference_file.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  calibd::LidarReferenceSet set;
  std::string error;
  if (!calibd::DecodeReferenceSet(bytes, &set, &error)) {
    Check(!error.empty(), "a refused file says why");
    return 0;
  }
  Check(set.dims > 0, "positive dims");
  Check(set.descriptors.size() == set.views.size() * static_cast<size_t>(set.dims),
        "dims values per view");
  for (float v : set.descriptors) calibd::fuzz::sink = calibd::fuzz::sink + v;
  Check(calibd::EncodeReferenceSet(set) == bytes, "encodes back to the same bytes");
  return 0;
}
