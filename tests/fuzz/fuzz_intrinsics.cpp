// Camera intrinsics files (OpenCV FileStorage YAML, ROS camera_info YAML, JSON) as
// LoadIntrinsicsFile reads them: ParseIntrinsics on the file's text.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/intrinsics_file.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string text(reinterpret_cast<const char*>(data), size);
  calibd::CameraIntrinsics intrinsics;
  std::string error;
  if (!calibd::ParseIntrinsics(text, "fuzz.yaml", &intrinsics, &error)) {
    Check(!error.empty(), "a refused file says why");
    return 0;
  }
  return 0;
}
