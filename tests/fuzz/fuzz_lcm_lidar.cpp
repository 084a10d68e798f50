// LCM lidar_frame_t bytes as the agent receives them: decoded like LcmBus, then checked and viewed
// by LidarFrameToView, as FrameIntake does (sizes that lie, NaN/inf, zero points, time offsets).

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/lcm_frames.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  calibd::lidar_frame_t msg;
  if (!calibd::fuzz::DecodeLikeTheBus(data, size, &msg)) return 0;
  const calibd::FrameLimits limits;
  calibd::PointCloudView view;
  std::string error;
  if (!calibd::LidarFrameToView(msg, limits, &view, &error)) {
    Check(!error.empty(), "a refused LiDAR frame says why");
    return 0;
  }
  const size_t n = view.size;
  Check(n == static_cast<size_t>(msg.num_points), "view has the message's point count");
  Check(msg.x.size() >= n && msg.y.size() >= n && msg.z.size() >= n && msg.ring.size() >= n &&
            msg.time_offset_us.size() >= n,
        "every array holds the viewed points");
  // Read every viewed element so ASan sees a view that points outside its arrays.
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    sum += static_cast<double>(view.x[i]) + view.y[i] + view.z[i];
    if (view.ring) sum += view.ring[i];
    if (view.time_offset_us) {
      Check(view.time_offset_us[i] >= -limits.max_time_offset_us &&
                view.time_offset_us[i] <= limits.max_time_offset_us,
            "time offsets within the limits");
    }
  }
  calibd::fuzz::sink = static_cast<double>(sum);
  return 0;
}
