#pragma once
/// \file
/// Picture of a frame: the camera image with LiDAR points projected through an extrinsic, coloured
/// by distance (paper Fig. 5 style). Used for the README picture and visual checks.

#include <opencv2/core.hpp>

#include "calibd/core/camera_model.hpp"
#include "lidar_sim.hpp"

namespace calibd::sim {

/// Draws `scan` projected with T_camera_lidar onto `mono8`, into `bgr`, scaled by `scale` (0.5
/// halves the size). Returns the number of points drawn.
int DrawLidarOverlay(const cv::Mat& mono8, const LidarScan& scan, const Pose& T_camera_lidar,
                     const CameraModel& camera, double scale, cv::Mat* bgr);

}  // namespace calibd::sim
