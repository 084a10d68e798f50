// LCM camera_frame_t bytes as the agent receives them: decoded like LcmBus, then checked and
// viewed (mono8 in place, bgr8 converted, JPEG decoded) by CameraFrameToView, as FrameIntake does.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/lcm_frames.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  calibd::camera_frame_t msg;
  if (!calibd::fuzz::DecodeLikeTheBus(data, size, &msg)) return 0;
  // Smaller limits than the agent's (16384 px) keep one decoded image below the fuzzer's memory
  // limit; the checks are the same code.
  calibd::FrameLimits limits;
  limits.max_width = 4096;
  limits.max_height = 4096;
  cv::Mat decoded;
  calibd::ImageView view;
  std::string error;
  if (!calibd::CameraFrameToView(msg, limits, &decoded, &view, &error)) {
    Check(!error.empty(), "a refused camera frame says why");
    return 0;
  }
  Check(view.width == msg.width && view.height == msg.height, "view has the message's size");
  Check(view.data != nullptr && view.stride >= view.width, "view has rows");
  if (msg.encoding == calibd::camera_frame_t::ENCODING_MONO8) {
    // Viewed in place: every row must lie inside the message's buffer.
    const size_t last = static_cast<size_t>(view.height - 1) * static_cast<size_t>(view.stride) +
                        static_cast<size_t>(view.width);
    Check(view.data == msg.data.data() && last <= msg.data.size(), "mono8 rows inside the data");
  }
  // Touch every pixel so ASan sees a view that points outside its buffer.
  unsigned sum = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) sum += view.data[static_cast<size_t>(r) * view.stride + c];
  calibd::fuzz::sink = static_cast<double>(sum);
  return 0;
}
