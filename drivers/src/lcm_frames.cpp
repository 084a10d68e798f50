#include "calibd/drivers/lcm_frames.hpp"

#include <opencv2/imgproc.hpp>

#include "calibd/core/common/validation.hpp"
#include "jpeg_decoder.hpp"

namespace calibd {

namespace {
std::string Size(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

/// Where a width x height grey image is written: the top-left corner of the caller's image when
/// that is large enough (the agent's intake sizes it once at the limits), else the caller's
/// image (re)allocated at this size. A view of it, not a copy: no allocation.
cv::Mat GreyTarget(cv::Mat* decoded, int width, int height) {
  if (decoded->type() != CV_8UC1 || decoded->cols < width || decoded->rows < height)
    decoded->create(height, width, CV_8UC1);
  return (*decoded)(cv::Rect(0, 0, width, height));
}

/// One decompressor per thread that decodes JPEG frames (the agent's camera thread), created by
/// its first JPEG frame and reused for every later one.
JpegDecoder& ThreadJpegDecoder() {
  thread_local JpegDecoder decoder;
  return decoder;
}
}  // namespace

bool CameraFrameToView(const camera_frame_t& m, const FrameLimits& limits, cv::Mat* decoded,
                       ImageView* view, std::string* error) {
  if (m.width <= 0 || m.height <= 0 || m.width > limits.max_width || m.height > limits.max_height)
    return Invalid(error, "camera_frame_t: width/height " + std::to_string(m.width) + "x" +
                              std::to_string(m.height) + " out of range");
  if (m.size < 0 || static_cast<size_t>(m.size) != m.data.size())
    return Invalid(error, "camera_frame_t: size " + std::to_string(m.size) + " does not match " +
                              std::to_string(m.data.size()) + " data bytes");
  switch (m.encoding) {
    case camera_frame_t::ENCODING_MONO8: {
      if (m.stride < m.width ||
          static_cast<int64_t>(m.stride) * (m.height - 1) + m.width > static_cast<int64_t>(m.size))
        return Invalid(error, "camera_frame_t: stride " + std::to_string(m.stride) +
                                  " and height do not fit in " + std::to_string(m.size) + " bytes");
      *view = ImageView{m.data.data(), m.width, m.height, m.stride};
      return true;
    }
    case camera_frame_t::ENCODING_BGR8: {
      if (m.stride < 3 * m.width || static_cast<int64_t>(m.stride) * (m.height - 1) + 3 * m.width >
                                        static_cast<int64_t>(m.size))
        return Invalid(error, "camera_frame_t: bgr8 stride " + std::to_string(m.stride) +
                                  " and height do not fit in " + std::to_string(m.size) + " bytes");
      const cv::Mat bgr(m.height, m.width, CV_8UC3, const_cast<uint8_t*>(m.data.data()),
                        static_cast<size_t>(m.stride));
      cv::Mat grey = GreyTarget(decoded, m.width, m.height);
      cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
      *view = ImageView{grey.data, m.width, m.height, static_cast<int>(grey.step[0])};
      return true;
    }
    case camera_frame_t::ENCODING_JPEG: {
      if (m.data.empty()) return Invalid(error, "camera_frame_t: empty JPEG data");
      JpegDecoder& jpeg = ThreadJpegDecoder();
      int width = 0, height = 0;
      if (!jpeg.ReadHeader(m.data.data(), m.data.size(), &width, &height))
        return Invalid(
            error, std::string("camera_frame_t: JPEG header does not decode: ") + jpeg.message());
      // The size is checked before a pixel is decoded (or a byte of libjpeg's buffers for them
      // allocated): the JPEG's own header can lie as well as the message's.
      if (width > limits.max_width || height > limits.max_height) {
        jpeg.Abort();
        return Invalid(error, "camera_frame_t: JPEG is " + Size(width, height) +
                                  ", beyond the limits " +
                                  Size(limits.max_width, limits.max_height));
      }
      if (width != m.width || height != m.height) {
        jpeg.Abort();
        return Invalid(error, "camera_frame_t: JPEG is " + Size(width, height) + ", header says " +
                                  Size(m.width, m.height));
      }
      cv::Mat grey = GreyTarget(decoded, width, height);
      if (!jpeg.Decode(grey.data, grey.step[0]))
        return Invalid(error,
                       std::string("camera_frame_t: JPEG data is damaged: ") + jpeg.message());
      *view = ImageView{grey.data, width, height, static_cast<int>(grey.step[0])};
      return true;
    }
    default:
      return Invalid(error, "camera_frame_t: unknown encoding " + std::to_string(m.encoding));
  }
}

bool LidarFrameToView(const lidar_frame_t& m, const FrameLimits& limits, PointCloudView* view,
                      std::string* error) {
  if (m.num_points < 0 || m.num_points > limits.max_points)
    return Invalid(error,
                   "lidar_frame_t: num_points " + std::to_string(m.num_points) + " out of range");
  const size_t n = static_cast<size_t>(m.num_points);
  if (m.x.size() != n || m.y.size() != n || m.z.size() != n || m.intensity.size() != n ||
      m.ring.size() != n || m.time_offset_us.size() != n)
    return Invalid(error,
                   "lidar_frame_t: array lengths differ from num_points " + std::to_string(n));
  bool any_ring = false;
  for (int16_t r : m.ring) any_ring = any_ring || r >= 0;
  for (size_t i = 0; i < n; ++i)
    if (m.time_offset_us[i] < -limits.max_time_offset_us ||
        m.time_offset_us[i] > limits.max_time_offset_us)
      return Invalid(error, "lidar_frame_t: time_offset_us[" + std::to_string(i) +
                                "] = " + std::to_string(m.time_offset_us[i]) + " us is beyond +-" +
                                std::to_string(limits.max_time_offset_us) + " us");
  *view = PointCloudView{m.x.data(), m.y.data(),
                         m.z.data(), any_ring ? m.ring.data() : nullptr,
                         n,          m.time_offset_us.data()};
  return true;
}

}  // namespace calibd
