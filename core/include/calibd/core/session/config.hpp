#pragma once
/// \file
/// The calibration configuration a user writes for a vehicle: sensors, intrinsics, boards and the
/// prior (mechanical design or last known) extrinsic. A plain struct with defaults, validated once.

#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"

namespace calibd {

struct CalibConfig {
  std::string camera_id = "front";
  CameraIntrinsics camera;
  /// camera.principal_point_sigma_px: how well the intrinsic calibration knows the principal
  /// point, px (one standard deviation per axis, as its report states: OpenCV's
  /// stdDeviationsIntrinsics, Kalibr's or the supplier's figure; 0.5-2 px is usual). 0: not
  /// stated, and then only the tags' own measurement of it counts (principal_point_check.hpp),
  /// which boards far off or seen head-on leave too loose for a result to be accepted.
  double principal_point_sigma_px = 0.0;
  std::string lidar_id = "roof";
  std::string lidar_model = "ot128";  ///< LidarKindFromName() names
  /// lidar.generic.*: overrides of the estimated scan geometry when lidar_model is "generic"
  /// (lidar_resolution.hpp); ignored otherwise.
  GenericLidarConfig lidar_generic;
  /// Frame names written into the exported calibration files (ROS tf, Autoware, JSON): the
  /// camera's and the LiDAR's frame ids. Letters, digits and `_ - . /`, not starting with `/`
  /// (tf2 rejects a leading slash); the two must differ.
  std::string camera_frame = "camera";
  std::string lidar_frame = "lidar";
  std::vector<BoardGeometry> boards;  ///< boards expected in the scene (ids must be distinct)
  /// Prior T_camera_lidar (maps LiDAR points into the camera frame), e.g. from the mechanical
  /// design.
  Pose prior_T_camera_lidar = Pose::Identity();

  /// Checks every field once; on failure `error` names the bad key (e.g. "boards[1].tag_size_m").
  bool IsValid(std::string* error) const;
};

}  // namespace calibd
