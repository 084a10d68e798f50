#pragma once
/// \file
/// Pictures for people: a camera image with LiDAR points projected through an extrinsic, coloured
/// by distance (paper Fig. 5 style), optionally with detected corners and LiDAR-fitted corners.

#include <opencv2/core.hpp>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/image_view.hpp"

namespace calibd::viz {

/// Draws `cloud` projected with T_camera_lidar onto `image`, into `bgr` scaled by `scale` (0.5
/// halves the size). Returns the number of points drawn.
int DrawLidarOverlay(const ImageView& image, const PointCloudView& cloud,
                     const Pose& T_camera_lidar, const CameraModel& camera, double scale,
                     cv::Mat* bgr);

/// Marks pixels (full-resolution coordinates) on an overlay made with `scale`: circles of `colour`.
void DrawMarkers(const std::vector<Eigen::Vector2d>& pixels, double scale, const cv::Scalar& colour,
                 cv::Mat* bgr);

}  // namespace calibd::viz
