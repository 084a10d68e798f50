// JPEG camera frames through libjpeg-turbo as the agent decodes them (CameraFrameToView with
// ENCODING_JPEG, jpeg_decoder.cpp): the input is the JPEG data itself, so the fuzzer mutates the
// image rather than the LCM wrapping; the message claims the size the data's own header gives
// when it has one (else 1x1), as a camera would.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/lcm_frames.hpp"
#include "fuzz_util.hpp"

namespace {

// The frame size from the first SOFn marker, or false: what a camera would put in the message.
bool JpegSize(const uint8_t* d, size_t n, int* w, int* h) {
  for (size_t i = 2; i + 9 < n; ++i) {
    if (d[i] != 0xFF) continue;
    const uint8_t m = d[i + 1];
    if (m >= 0xC0 && m <= 0xCF && m != 0xC4 && m != 0xC8 && m != 0xCC) {
      *h = d[i + 5] << 8 | d[i + 6];
      *w = d[i + 7] << 8 | d[i + 8];
      return true;
    }
  }
  return false;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  calibd::camera_frame_t msg;
  msg.camera_id = "cam0";
  msg.width = msg.height = 1;
  JpegSize(data, size, &msg.width, &msg.height);
  msg.stride = 0;
  msg.encoding = calibd::camera_frame_t::ENCODING_JPEG;
  msg.data.assign(data, data + size);
  msg.size = static_cast<int32_t>(size);
  calibd::FrameLimits limits;
  limits.max_width = 4096;
  limits.max_height = 4096;
  // A reused image as in FrameIntake, sometimes too small so that the decoder reallocates.
  static cv::Mat decoded(512, 512, CV_8UC1);
  calibd::ImageView view;
  std::string error;
  if (!calibd::CameraFrameToView(msg, limits, &decoded, &view, &error)) {
    Check(!error.empty(), "a refused JPEG says why");
    return 0;
  }
  Check(view.width == msg.width && view.height == msg.height, "view has the header's size");
  Check(view.stride >= view.width && view.data != nullptr, "view has rows");
  unsigned sum = 0;
  for (int r = 0; r < view.height; ++r)
    for (int c = 0; c < view.width; ++c) sum += view.data[static_cast<size_t>(r) * view.stride + c];
  calibd::fuzz::sink = static_cast<double>(sum);
  return 0;
}
