#include "lcm_output.hpp"

#include <cstring>
#include <opencv2/imgcodecs.hpp>

namespace calibd::sim {

bool ToCameraMessage(const cv::Mat& mono8, int64_t utime, const std::string& camera_id,
                     int8_t encoding, int jpeg_quality, calibd::camera_frame_t* msg) {
  msg->utime = utime;
  msg->camera_id = camera_id;
  msg->width = mono8.cols;
  msg->height = mono8.rows;
  msg->encoding = encoding;
  if (encoding == calibd::camera_frame_t::ENCODING_JPEG) {
    msg->stride = 0;
    if (!cv::imencode(".jpg", mono8, msg->data, {cv::IMWRITE_JPEG_QUALITY, jpeg_quality}))
      return false;
    msg->size = static_cast<int32_t>(msg->data.size());
    return true;
  }
  msg->stride = mono8.cols;  // rows are packed below
  msg->size = mono8.cols * mono8.rows;
  msg->data.resize(static_cast<size_t>(msg->size));
  for (int r = 0; r < mono8.rows; ++r) {
    std::memcpy(msg->data.data() + static_cast<size_t>(r) * mono8.cols, mono8.ptr(r),
                static_cast<size_t>(mono8.cols));
  }
  return true;
}

void ToLidarMessage(const LidarScan& scan, int64_t utime, const std::string& lidar_id,
                    calibd::lidar_frame_t* msg) {
  msg->utime = utime;
  msg->lidar_id = lidar_id;
  msg->num_points = static_cast<int32_t>(scan.size());
  msg->x.assign(scan.x.begin(), scan.x.end());
  msg->y.assign(scan.y.begin(), scan.y.end());
  msg->z.assign(scan.z.begin(), scan.z.end());
  msg->intensity.assign(scan.intensity.begin(), scan.intensity.end());
  msg->ring.assign(scan.ring.begin(), scan.ring.end());
  msg->time_offset_us.assign(scan.time_offset_us.begin(), scan.time_offset_us.end());
}

}  // namespace calibd::sim
