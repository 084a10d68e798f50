#pragma once
/// \file
/// The calibration in the file formats other stacks read: a JSON document, an
/// OpenCV FileStorage YAML, ROS `static_transform_publisher` command lines, a tf-style YAML,
/// Autoware's sensor-kit calibration YAML and KITTI's `calib_velo_to_cam.txt`.
///
/// Direction, in every format: the parent (reference) frame is the camera, the child the LiDAR,
/// and the transform is T_camera_lidar (p_camera = T_camera_lidar * p_lidar), i.e. the LiDAR's
/// pose in the camera frame, which is what a tf from the camera to the LiDAR frame carries. The
/// JSON and the OpenCV file also hold the inverse, T_lidar_camera.
///
/// Numbers are written so that they read back to the same double (shortest round-trip decimal;
/// cv::FileStorage's own %.16e in the OpenCV file). Quaternions are unit, ordered x y z w, with
/// w >= 0 (q and -q are the same rotation; the non-negative w makes the text unique).
/// Roll/pitch/yaw are RpyFromRotation's: R = Rz(yaw) Ry(pitch) Rx(roll), radians, pitch in
/// [-pi/2, pi/2] (tf2's setRPY and Autoware's convention).
///
/// The Format*() functions are pure text; WriteCalibrationExports() writes every file of a set.

#include <cstdint>
#include <nlohmann/json.hpp>
#include <string>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

/// What every export is made from. A value type.
struct CalibrationExport {
  /// Maps LiDAR points into the camera frame: p_camera = T_camera_lidar * p_lidar.
  Pose T_camera_lidar = Pose::Identity();
  std::string camera_frame = "camera";  ///< parent frame id (CalibConfig::camera_frame)
  std::string lidar_frame = "lidar";    ///< child frame id (CalibConfig::lidar_frame)
  std::string software_version;         ///< e.g. "calibd 0.1.0"
  /// When the calibration was made, Unix time in s (KITTI's calib_time, in UTC).
  int64_t calibrated_unix_s = 0;
};

/// A transform as JSON: "matrix" (4x4 rows), "xyz_m", "quaternion_xyzw" (unit, w >= 0) and
/// "rpy_deg" (RpyFromRotation's convention). The block calibd-calibrate's report uses too.
nlohmann::json TransformJson(const Pose& T_a_b);

/// Unit quaternion of T's rotation as x, y, z, w with w >= 0.
Eigen::Vector4d QuaternionXyzw(const Eigen::Matrix3d& R);

/// JSON document: format name and version, frame names, software version, calibration time,
/// "T_camera_lidar" and "T_lidar_camera" as TransformJson blocks.
std::string FormatExportJson(const CalibrationExport& e);

/// OpenCV FileStorage YAML (`%YAML:1.0`), written with cv::FileStorage: T_camera_lidar and
/// T_lidar_camera (4x4), R_camera_lidar (3x3), t_camera_lidar (3x1, m) as !!opencv-matrix of
/// doubles, and the strings camera_frame, lidar_frame, software_version.
std::string FormatOpenCvYaml(const CalibrationExport& e);

/// `rosrun tf2_ros static_transform_publisher x y z qx qy qz qw <camera_frame> <lidar_frame>`
/// (ROS 1). tf2 reads the arguments as the child frame's pose in the parent frame: T_camera_lidar.
std::string FormatRos1StaticTransformCommand(const CalibrationExport& e);

/// `ros2 run tf2_ros static_transform_publisher --x .. --y .. --z .. --qx .. --qy .. --qz ..
/// --qw .. --frame-id <camera_frame> --child-frame-id <lidar_frame>` (ROS 2 Humble and later).
std::string FormatRos2StaticTransformCommand(const CalibrationExport& e);

/// Both commands with comment lines saying which is which (a text file, not a script to run:
/// a tf tree takes one of them).
std::string FormatRosStaticTransformFile(const CalibrationExport& e);

/// tf-style YAML in geometry_msgs/TransformStamped's layout: header.frame_id (camera),
/// child_frame_id (LiDAR), transform.translation {x, y, z} in m and transform.rotation
/// {x, y, z, w}.
std::string FormatTfYaml(const CalibrationExport& e);

/// Autoware's sensor_kit_calibration.yaml layout: `<camera_frame>:` / `  <lidar_frame>:` /
/// `    x: y: z: roll: pitch: yaw:` in m and radians: the child's pose in the parent frame
/// (T_camera_lidar) with R = Rz(yaw) Ry(pitch) Rx(roll), as Autoware's launch files pass it to
/// tf2 (setRPY). Near pitch = +-90 deg (a forward camera's T_camera_lidar, docs/conventions.md
/// #euler) roll and yaw are individually ill-defined but their combination is exact.
std::string FormatAutowareSensorKitYaml(const CalibrationExport& e);

/// KITTI's calib_velo_to_cam.txt: `calib_time: dd-Mon-yyyy HH:MM:SS` (UTC), `R:` 9 numbers row
/// by row, `T:` 3 numbers (m), and `delta_f: 0 0` / `delta_c: 0 0` as KITTI writes them. R and T
/// are T_camera_lidar's (KITTI's velodyne-to-camera transform maps velodyne points into the
/// camera frame).
std::string FormatKittiVeloToCam(const CalibrationExport& e);

/// File names in an export directory, one per format.
struct ExportFileNames {
  static constexpr const char* kJson = "calibration.json";
  static constexpr const char* kOpenCv = "T_camera_lidar_opencv.yaml";
  static constexpr const char* kRos = "ros_static_transform_publisher.txt";
  static constexpr const char* kTf = "T_camera_lidar_tf.yaml";
  static constexpr const char* kAutoware = "sensor_kit_calibration.yaml";
  static constexpr const char* kKitti = "calib_velo_to_cam.txt";
};

/// Writes every format into `directory` (created if missing, its parent must exist), each file
/// with WriteFileAtomic: a crash leaves each file old or new, never torn; the set is not replaced
/// as one, so files of two calibrations can sit side by side after a crash mid-way (each says
/// when it was made). On failure `error` names the path.
bool WriteCalibrationExports(const std::string& directory, const CalibrationExport& e,
                             std::string* error);

}  // namespace calibd
