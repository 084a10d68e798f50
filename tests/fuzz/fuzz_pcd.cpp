// PCD files (ascii, binary, binary_compressed) as calibd-calibrate --folder and calibd-import
// read them: ParsePcd on the file's bytes (ReadPcdFile reads the file, then calls it).

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/pcd_reader.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string bytes(reinterpret_cast<const char*>(data), size);
  // A smaller point limit than the default 4 M keeps a lying header below the memory limit.
  calibd::PcdReadOptions options;
  options.max_points = 1 << 20;
  calibd::lidar_frame_t cloud;
  calibd::PcdInfo info;
  std::string error;
  if (!calibd::ParsePcd(bytes, "fuzz.pcd", options, &cloud, &info, &error)) {
    Check(error.rfind("fuzz.pcd", 0) == 0, "a refused PCD's error names the file");
    return 0;
  }
  const size_t n = static_cast<size_t>(cloud.num_points);
  Check(cloud.num_points >= 0 && cloud.num_points <= options.max_points, "point count in range");
  Check(cloud.x.size() == n && cloud.y.size() == n && cloud.z.size() == n &&
            cloud.intensity.size() == n && cloud.ring.size() == n &&
            cloud.time_offset_us.size() == n,
        "every array holds num_points");
  Check(info.points == static_cast<int64_t>(n) + info.nan_dropped, "points = kept + dropped");
  for (size_t i = 0; i < n; ++i)
    Check(std::isfinite(cloud.x[i]) && std::isfinite(cloud.y[i]) && std::isfinite(cloud.z[i]),
          "no non-finite point kept");
  return 0;
}
