#include "overlay.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

namespace calibd::viz {

int DrawLidarOverlay(const ImageView& image, const PointCloudView& cloud,
                     const Pose& T_camera_lidar, const CameraModel& camera, double scale,
                     cv::Mat* bgr) {
  const cv::Mat grey(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data),
                     static_cast<size_t>(image.stride));
  cv::Mat small;
  cv::resize(grey, small, cv::Size(), scale, scale, cv::INTER_AREA);
  cv::cvtColor(small, *bgr, cv::COLOR_GRAY2BGR);
  // Colour by distance on a log scale, 3 m (red) to 60 m (blue), via OpenCV's JET map.
  cv::Mat lut_in(1, 256, CV_8UC1), lut;
  for (int i = 0; i < 256; ++i) lut_in.at<uint8_t>(0, i) = static_cast<uint8_t>(255 - i);
  cv::applyColorMap(lut_in, lut, cv::COLORMAP_JET);
  int drawn = 0;
  for (size_t i = 0; i < cloud.size; ++i) {
    const Eigen::Vector3d p_lidar(cloud.x[i], cloud.y[i], cloud.z[i]);
    if (!p_lidar.allFinite()) continue;
    const Eigen::Vector3d p_camera = T_camera_lidar * p_lidar;
    Eigen::Vector2d uv;
    if (!camera.Project(p_camera, &uv)) continue;
    const double d = p_camera.norm();
    const double s = std::clamp(std::log(d / 3.0) / std::log(60.0 / 3.0), 0.0, 1.0);
    const cv::Vec3b c = lut.at<cv::Vec3b>(0, static_cast<int>(s * 255.0));
    const cv::Point pt(static_cast<int>(std::lround(uv.x() * scale)),
                       static_cast<int>(std::lround(uv.y() * scale)));
    cv::circle(*bgr, pt, 1, cv::Scalar(c[0], c[1], c[2]), cv::FILLED, cv::LINE_8);
    ++drawn;
  }
  return drawn;
}

void DrawMarkers(const std::vector<Eigen::Vector2d>& pixels, double scale, const cv::Scalar& colour,
                 cv::Mat* bgr) {
  for (const auto& p : pixels) {
    const cv::Point pt(static_cast<int>(std::lround(p.x() * scale)),
                       static_cast<int>(std::lround(p.y() * scale)));
    cv::circle(*bgr, pt, 5, colour, 2, cv::LINE_AA);
  }
}

}  // namespace calibd::viz
