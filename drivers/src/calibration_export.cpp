#include "calibd/drivers/calibration_export.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <opencv2/core.hpp>
#include <opencv2/core/eigen.hpp>
#include <sstream>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"

namespace calibd {

namespace {

constexpr int kExportFormatVersion = 1;

// KITTI's calib_time text ("15-Mar-2012 11:37:16"), UTC, month names in English whatever the
// locale (strftime's %b is not).
std::string KittiTime(int64_t unix_s) {
  static constexpr const char* kMonths[] = {"Jan", "Feb", "Mar", "Apr", "May", "Jun",
                                            "Jul", "Aug", "Sep", "Oct", "Nov", "Dec"};
  const std::time_t t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[64];
  std::snprintf(text, sizeof(text), "%02d-%s-%04d %02d:%02d:%02d", tm.tm_mday,
                kMonths[tm.tm_mon % 12], tm.tm_year + 1900, tm.tm_hour, tm.tm_min, tm.tm_sec);
  return text;
}

std::string IsoTime(int64_t unix_s) {
  const std::time_t t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  gmtime_r(&t, &tm);
  char text[64];
  std::strftime(text, sizeof(text), "%Y-%m-%dT%H:%M:%SZ", &tm);
  return text;
}

// The header comment of the YAML and text files: what, which direction, when, by what.
std::string Header(const CalibrationExport& e, const char* what) {
  return std::string("# ") + what + "\n# T_camera_lidar: parent frame '" + e.camera_frame +
         "', child frame '" + e.lidar_frame +
         "' (maps LiDAR points into the camera frame)\n# calibrated " +
         IsoTime(e.calibrated_unix_s) + " by " + e.software_version + "\n";
}

}  // namespace

Eigen::Vector4d QuaternionXyzw(const Eigen::Matrix3d& R) {
  Eigen::Quaterniond q(R);
  q.normalize();
  if (q.w() < 0.0) q.coeffs() = -q.coeffs();
  return q.coeffs();  // Eigen stores x, y, z, w
}

nlohmann::json TransformJson(const Pose& T_a_b) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r)
    rows.push_back(
        {T_a_b.matrix()(r, 0), T_a_b.matrix()(r, 1), T_a_b.matrix()(r, 2), T_a_b.matrix()(r, 3)});
  const Eigen::Vector3d t = T_a_b.translation();
  const Eigen::Vector4d q = QuaternionXyzw(T_a_b.linear());
  const Eigen::Vector3d rpy = RpyFromRotation(T_a_b.linear()) * kRad2Deg;
  return {{"matrix", rows},
          {"xyz_m", {t.x(), t.y(), t.z()}},
          {"quaternion_xyzw", {q.x(), q.y(), q.z(), q.w()}},
          {"rpy_deg", {rpy.x(), rpy.y(), rpy.z()}}};
}

std::string FormatExportJson(const CalibrationExport& e) {
  nlohmann::json j;
  j["format"] = "calibd.extrinsic";
  j["format_version"] = kExportFormatVersion;
  j["conventions"] =
      "T_a_b maps points from frame b into frame a; quaternion x y z w with w >= 0; rpy_deg: R = "
      "Rz(yaw) Ry(pitch) Rx(roll)";
  j["camera_frame"] = e.camera_frame;
  j["lidar_frame"] = e.lidar_frame;
  j["software_version"] = e.software_version;
  j["calibrated_unix_s"] = e.calibrated_unix_s;
  j["calibrated_utc"] = IsoTime(e.calibrated_unix_s);
  j["T_camera_lidar"] = TransformJson(e.T_camera_lidar);
  j["T_lidar_camera"] = TransformJson(e.T_camera_lidar.inverse());
  // nlohmann writes doubles with max_digits10 (they read back exactly).
  return j.dump(2) + "\n";
}

std::string FormatOpenCvYaml(const CalibrationExport& e) {
  cv::FileStorage fs(
      ".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY | cv::FileStorage::FORMAT_YAML);
  const Eigen::Matrix4d T_cl = e.T_camera_lidar.matrix();
  const Eigen::Matrix4d T_lc = e.T_camera_lidar.inverse().matrix();
  const Eigen::Matrix3d R = e.T_camera_lidar.linear();
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  cv::Mat m;
  fs.writeComment("calibd LiDAR-camera extrinsic; T_a_b maps points from frame b into frame a");
  cv::eigen2cv(T_cl, m);
  fs << "T_camera_lidar" << m;
  cv::eigen2cv(T_lc, m);
  fs << "T_lidar_camera" << m;
  cv::eigen2cv(R, m);
  fs << "R_camera_lidar" << m;
  cv::eigen2cv(t, m);
  fs << "t_camera_lidar" << m;
  fs << "camera_frame" << e.camera_frame;
  fs << "lidar_frame" << e.lidar_frame;
  fs << "software_version" << e.software_version;
  fs << "calibrated_utc" << IsoTime(e.calibrated_unix_s);
  return fs.releaseAndGetString();
}

std::string FormatRos1StaticTransformCommand(const CalibrationExport& e) {
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  const Eigen::Vector4d q = QuaternionXyzw(e.T_camera_lidar.linear());
  return "rosrun tf2_ros static_transform_publisher " + ShortestDecimal(t.x()) + " " +
         ShortestDecimal(t.y()) + " " + ShortestDecimal(t.z()) + " " + ShortestDecimal(q.x()) +
         " " + ShortestDecimal(q.y()) + " " + ShortestDecimal(q.z()) + " " +
         ShortestDecimal(q.w()) + " " + e.camera_frame + " " + e.lidar_frame;
}

std::string FormatRos2StaticTransformCommand(const CalibrationExport& e) {
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  const Eigen::Vector4d q = QuaternionXyzw(e.T_camera_lidar.linear());
  return "ros2 run tf2_ros static_transform_publisher --x " + ShortestDecimal(t.x()) + " --y " +
         ShortestDecimal(t.y()) + " --z " + ShortestDecimal(t.z()) + " --qx " +
         ShortestDecimal(q.x()) + " --qy " + ShortestDecimal(q.y()) + " --qz " +
         ShortestDecimal(q.z()) + " --qw " + ShortestDecimal(q.w()) + " --frame-id " +
         e.camera_frame + " --child-frame-id " + e.lidar_frame;
}

std::string FormatRosStaticTransformFile(const CalibrationExport& e) {
  return Header(e, "calibd: static tf from the camera to the LiDAR frame (run one of these)") +
         "# ROS 1:\n" + FormatRos1StaticTransformCommand(e) + "\n# ROS 2:\n" +
         FormatRos2StaticTransformCommand(e) + "\n";
}

std::string FormatTfYaml(const CalibrationExport& e) {
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  const Eigen::Vector4d q = QuaternionXyzw(e.T_camera_lidar.linear());
  std::ostringstream o;
  o << Header(e, "calibd: T_camera_lidar as a geometry_msgs/TransformStamped (tf)")
    << "header:\n  frame_id: \"" << e.camera_frame << "\"\nchild_frame_id: \"" << e.lidar_frame
    << "\"\ntransform:\n  translation:\n    x: " << ShortestDecimal(t.x())
    << "\n    y: " << ShortestDecimal(t.y()) << "\n    z: " << ShortestDecimal(t.z())
    << "\n  rotation:\n    x: " << ShortestDecimal(q.x()) << "\n    y: " << ShortestDecimal(q.y())
    << "\n    z: " << ShortestDecimal(q.z()) << "\n    w: " << ShortestDecimal(q.w()) << "\n";
  return o.str();
}

std::string FormatAutowareSensorKitYaml(const CalibrationExport& e) {
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  const Eigen::Vector3d rpy = RpyFromRotation(e.T_camera_lidar.linear());
  std::ostringstream o;
  o << Header(e, "calibd: Autoware sensor_kit_calibration.yaml layout")
    << "# <parent>: <child>: the child's pose in the parent frame; x y z in m, roll pitch yaw in\n"
    << "# rad with R = Rz(yaw) Ry(pitch) Rx(roll) (tf2 setRPY)\n"
    << "\"" << e.camera_frame << "\":\n  \"" << e.lidar_frame
    << "\":\n    x: " << ShortestDecimal(t.x()) << "\n    y: " << ShortestDecimal(t.y())
    << "\n    z: " << ShortestDecimal(t.z()) << "\n    roll: " << ShortestDecimal(rpy.x())
    << "\n    pitch: " << ShortestDecimal(rpy.y()) << "\n    yaw: " << ShortestDecimal(rpy.z())
    << "\n";
  return o.str();
}

std::string FormatKittiVeloToCam(const CalibrationExport& e) {
  const Eigen::Matrix3d R = e.T_camera_lidar.linear();
  const Eigen::Vector3d t = e.T_camera_lidar.translation();
  std::string s = "calib_time: " + KittiTime(e.calibrated_unix_s) + "\nR:";
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) s += " " + ShortestDecimal(R(r, c));
  s += "\nT: " + ShortestDecimal(t.x()) + " " + ShortestDecimal(t.y()) + " " +
       ShortestDecimal(t.z());
  // KITTI's files end with these two (zero in every released sequence).
  s += "\ndelta_f: 0 0\ndelta_c: 0 0\n";
  return s;
}

bool WriteCalibrationExports(const std::string& directory, const CalibrationExport& e,
                             std::string* error) {
  if (::mkdir(directory.c_str(), 0755) != 0 && errno != EEXIST) {
    if (error) *error = directory + ": cannot create directory: " + std::strerror(errno);
    return false;
  }
  using F = ExportFileNames;
  const std::pair<const char*, std::string> files[] = {
      {F::kJson, FormatExportJson(e)},
      {F::kOpenCv, FormatOpenCvYaml(e)},
      {F::kRos, FormatRosStaticTransformFile(e)},
      {F::kTf, FormatTfYaml(e)},
      {F::kAutoware, FormatAutowareSensorKitYaml(e)},
      {F::kKitti, FormatKittiVeloToCam(e)},
  };
  for (const auto& [name, text] : files)
    if (!WriteFileAtomic(directory + "/" + name, text, error)) return false;
  return true;
}

}  // namespace calibd
