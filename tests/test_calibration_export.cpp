// The exported calibration files (drivers/calibration_export.hpp): every format is read back with
// a real parser (nlohmann, cv::FileStorage, yaml-cpp, plain text for KITTI and the ROS lines), the
// transform rebuilt from what was read and compared with the input pose to 1e-9, in both
// directions, so an inverted or transposed transform fails.

#include <gtest/gtest.h>
#include <yaml-cpp/yaml.h>

#include <cmath>
#include <map>
#include <opencv2/core.hpp>
#include <random>
#include <regex>
#include <sstream>
#include <vector>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

constexpr double kTol = 1e-9;

// calibd-sim's default mechanical design (deploy/config/calibd.yaml): the camera looks forward,
// so T_camera_lidar sits exactly at pitch = -90 deg.
Pose ForwardCamera() {
  Pose T = Pose::Identity();
  T.linear() << 0, -1, 0, 0, 0, -1, 1, 0, 0;
  T.translation() << 0.05, -0.5, -0.4;
  return T;
}

// The poses every format is checked with: the exact forward design (gimbal lock), the design
// slightly perturbed (near it), and random rotations, a quarter of them with w < 0 in Eigen's
// own conversion.
std::vector<Pose> TestPoses() {
  std::vector<Pose> poses{ForwardCamera()};
  Pose near = ForwardCamera();
  near.linear() =
      near.linear() *
      Eigen::AngleAxisd(0.3 * kDeg2Rad, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  poses.push_back(near);
  Pose tiny = ForwardCamera();  // 1e-7 rad from the lock: roll and yaw nearly degenerate
  tiny.linear() =
      tiny.linear() * Eigen::AngleAxisd(1e-7, Eigen::Vector3d::UnitY()).toRotationMatrix();
  poses.push_back(tiny);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int i = 0; i < 20; ++i) {
    Pose T = Pose::Identity();
    T.linear() = Eigen::Quaterniond(u(rng), u(rng), u(rng), u(rng)).normalized().toRotationMatrix();
    T.translation() << 3 * u(rng), 3 * u(rng), 3 * u(rng);
    poses.push_back(T);
  }
  return poses;
}

// A matrix read by cv::FileStorage, element by element (its type must be double).
Eigen::MatrixXd ToEigen(const cv::Mat& m) {
  EXPECT_EQ(m.type(), CV_64F);
  Eigen::MatrixXd out(m.rows, m.cols);
  for (int r = 0; r < m.rows; ++r)
    for (int c = 0; c < m.cols; ++c) out(r, c) = m.type() == CV_64F ? m.at<double>(r, c) : NAN;
  return out;
}

Pose PoseFromMatrix(const Eigen::MatrixXd& M) {
  EXPECT_EQ(M.rows(), 4);
  EXPECT_EQ(M.cols(), 4);
  Pose T = Pose::Identity();
  if (M.rows() == 4 && M.cols() == 4) T.matrix() = M;
  return T;
}

CalibrationExport Export(const Pose& T) {
  CalibrationExport e;
  e.T_camera_lidar = T;
  e.camera_frame = "cam_front/optical";
  e.lidar_frame = "lidar_roof";
  e.software_version = "calibd 9.8.7-test";
  e.calibrated_unix_s = 1331811436;  // 2012-03-15 11:37:16 UTC, the date in KITTI's own file
  return e;
}

Pose FromXyzQuat(double x, double y, double z, double qx, double qy, double qz, double qw) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(qw, qx, qy, qz).normalized().toRotationMatrix();
  T.translation() << x, y, z;
  return T;
}

// Requires `read` to be T_camera_lidar in both directions: the matrices, their inverses, and a
// LiDAR point mapped into the camera frame (an inverted transform maps it elsewhere).
void ExpectSamePose(const Pose& read, const Pose& T_camera_lidar, const std::string& what) {
  EXPECT_LT((read.matrix() - T_camera_lidar.matrix()).cwiseAbs().maxCoeff(), kTol)
      << what << "\nread:\n"
      << read.matrix() << "\nexpected T_camera_lidar:\n"
      << T_camera_lidar.matrix();
  EXPECT_LT((read.inverse().matrix() - T_camera_lidar.inverse().matrix()).cwiseAbs().maxCoeff(),
            kTol)
      << what;
  const Eigen::Vector3d p_lidar(10.0, -2.0, 1.5);
  EXPECT_LT((read * p_lidar - T_camera_lidar * p_lidar).norm(), kTol) << what;
}

std::vector<std::string> Words(const std::string& line) {
  std::istringstream in(line);
  std::vector<std::string> words;
  for (std::string w; in >> w;) words.push_back(w);
  return words;
}

// The non-comment lines of a text.
std::vector<std::string> Lines(const std::string& text) {
  std::istringstream in(text);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);)
    if (!l.empty() && l[0] != '#') lines.push_back(l);
  return lines;
}

TEST(CalibrationExportTest, QuaternionIsUnitWithNonNegativeW) {
  int negative_in_eigen = 0;
  for (const Pose& T : TestPoses()) {
    if (Eigen::Quaterniond(T.linear()).w() < 0.0) ++negative_in_eigen;
    const Eigen::Vector4d q = QuaternionXyzw(T.linear());
    EXPECT_NEAR(q.norm(), 1.0, 1e-15);
    EXPECT_GE(q.w(), 0.0);
    const Eigen::Matrix3d R = Eigen::Quaterniond(q.w(), q.x(), q.y(), q.z()).toRotationMatrix();
    EXPECT_LT((R - T.linear()).cwiseAbs().maxCoeff(), kTol);
  }
  // A rotation by more than 180 deg written as angle-axis: Eigen keeps w < 0 there.
  const Eigen::Quaterniond q_neg(Eigen::AngleAxisd(1.9 * M_PI, Eigen::Vector3d(0, 0.6, 0.8)));
  ASSERT_LT(q_neg.w(), 0.0);
  const Eigen::Vector4d q = QuaternionXyzw(q_neg.toRotationMatrix());
  EXPECT_GT(q.w(), 0.0);
  EXPECT_LT((q + q_neg.coeffs()).norm(), 1e-12);  // the same rotation, sign flipped
  // The sign flip was exercised by the test poses too, not only by the constructed one.
  EXPECT_GT(negative_in_eigen, 0);
}

TEST(CalibrationExportTest, JsonHoldsBothDirectionsAndTheFrames) {
  for (const Pose& T : TestPoses()) {
    const auto j = nlohmann::json::parse(FormatExportJson(Export(T)));
    EXPECT_EQ(j["format"], "calibd.extrinsic");
    EXPECT_EQ(j["camera_frame"], "cam_front/optical");
    EXPECT_EQ(j["lidar_frame"], "lidar_roof");
    EXPECT_EQ(j["software_version"], "calibd 9.8.7-test");
    EXPECT_EQ(j["calibrated_utc"], "2012-03-15T11:37:16Z");
    for (const char* name : {"T_camera_lidar", "T_lidar_camera"}) {
      const Pose expected = std::string(name) == "T_camera_lidar" ? T : T.inverse();
      const auto& b = j[name];
      Pose M = Pose::Identity();
      for (int r = 0; r < 4; ++r)
        for (int c = 0; c < 4; ++c) M.matrix()(r, c) = b["matrix"][r][c].get<double>();
      ExpectSamePose(M, expected, std::string("json matrix ") + name);
      const auto& t = b["xyz_m"];
      const auto& q = b["quaternion_xyzw"];
      EXPECT_GE(q[3].get<double>(), 0.0);
      ExpectSamePose(FromXyzQuat(t[0], t[1], t[2], q[0], q[1], q[2], q[3]), expected,
                     std::string("json xyz+quaternion ") + name);
      const auto& rpy = b["rpy_deg"];
      Pose E = Pose::Identity();
      E.linear() = RotationFromRpy(rpy[0].get<double>() * kDeg2Rad, rpy[1].get<double>() * kDeg2Rad,
                                   rpy[2].get<double>() * kDeg2Rad);
      E.translation() << t[0], t[1], t[2];
      ExpectSamePose(E, expected, std::string("json xyz+rpy ") + name);
    }
  }
}

TEST(CalibrationExportTest, OpenCvYamlReadsBackWithFileStorage) {
  for (const Pose& T : TestPoses()) {
    const std::string text = FormatOpenCvYaml(Export(T));
    EXPECT_EQ(text.rfind("%YAML:1.0", 0), 0u) << text;
    EXPECT_NE(text.find("!!opencv-matrix"), std::string::npos) << text;
    cv::FileStorage fs(text, cv::FileStorage::READ | cv::FileStorage::MEMORY);
    ASSERT_TRUE(fs.isOpened());
    cv::Mat m;
    fs["T_camera_lidar"] >> m;
    ExpectSamePose(PoseFromMatrix(ToEigen(m)), T, "opencv T_camera_lidar");
    fs["T_lidar_camera"] >> m;
    ExpectSamePose(PoseFromMatrix(ToEigen(m)).inverse(), T, "opencv T_lidar_camera inverted");
    cv::Mat R, t;
    fs["R_camera_lidar"] >> R;
    fs["t_camera_lidar"] >> t;
    ASSERT_EQ(R.rows * R.cols + t.rows * t.cols, 12) << text;
    Pose Rt = Pose::Identity();
    Rt.linear() = ToEigen(R);
    Rt.translation() = ToEigen(t);
    ExpectSamePose(Rt, T, "opencv R, t");
    EXPECT_EQ(static_cast<std::string>(fs["camera_frame"]), "cam_front/optical");
    EXPECT_EQ(static_cast<std::string>(fs["lidar_frame"]), "lidar_roof");
    EXPECT_EQ(static_cast<std::string>(fs["software_version"]), "calibd 9.8.7-test");
  }
}

TEST(CalibrationExportTest, Ros1CommandCarriesTCameraLidarFromCameraToLidar) {
  for (const Pose& T : TestPoses()) {
    const std::vector<std::string> w = Words(FormatRos1StaticTransformCommand(Export(T)));
    ASSERT_EQ(w.size(), 12u);
    EXPECT_EQ(w[0], "rosrun");
    EXPECT_EQ(w[1], "tf2_ros");
    EXPECT_EQ(w[2], "static_transform_publisher");
    // x y z qx qy qz qw frame_id child_frame_id: the child's pose in the parent frame.
    double v[7];
    for (int i = 0; i < 7; ++i) {
      size_t used = 0;
      v[i] = std::stod(w[3 + i], &used);
      EXPECT_EQ(used, w[3 + i].size()) << w[3 + i];
    }
    EXPECT_EQ(w[10], "cam_front/optical");  // parent
    EXPECT_EQ(w[11], "lidar_roof");         // child
    EXPECT_NEAR(std::hypot(std::hypot(v[3], v[4]), std::hypot(v[5], v[6])), 1.0, 1e-15);
    EXPECT_GE(v[6], 0.0);
    ExpectSamePose(FromXyzQuat(v[0], v[1], v[2], v[3], v[4], v[5], v[6]), T, "ROS 1 line");
  }
}

TEST(CalibrationExportTest, Ros2CommandCarriesTCameraLidarFromCameraToLidar) {
  for (const Pose& T : TestPoses()) {
    const std::vector<std::string> w = Words(FormatRos2StaticTransformCommand(Export(T)));
    ASSERT_EQ(w.size(), 22u);
    EXPECT_EQ(w[0], "ros2");
    EXPECT_EQ(w[1], "run");
    EXPECT_EQ(w[2], "tf2_ros");
    EXPECT_EQ(w[3], "static_transform_publisher");
    std::map<std::string, std::string> args;
    for (size_t i = 4; i + 1 < w.size(); i += 2) {
      ASSERT_EQ(w[i].rfind("--", 0), 0u) << w[i];
      EXPECT_TRUE(args.emplace(w[i], w[i + 1]).second) << "repeated " << w[i];
    }
    EXPECT_EQ(args.at("--frame-id"), "cam_front/optical");
    EXPECT_EQ(args.at("--child-frame-id"), "lidar_roof");
    auto num = [&](const char* k) { return std::stod(args.at(k)); };
    ExpectSamePose(FromXyzQuat(num("--x"), num("--y"), num("--z"), num("--qx"), num("--qy"),
                               num("--qz"), num("--qw")),
                   T, "ROS 2 line");
  }
}

TEST(CalibrationExportTest, RosFileHoldsBothCommands) {
  const CalibrationExport e = Export(ForwardCamera());
  const std::vector<std::string> lines = Lines(FormatRosStaticTransformFile(e));
  ASSERT_EQ(lines.size(), 2u);
  EXPECT_EQ(lines[0], FormatRos1StaticTransformCommand(e));
  EXPECT_EQ(lines[1], FormatRos2StaticTransformCommand(e));
}

TEST(CalibrationExportTest, TfYamlReadsBackWithYamlCpp) {
  for (const Pose& T : TestPoses()) {
    const YAML::Node y = YAML::Load(FormatTfYaml(Export(T)));
    EXPECT_EQ(y["header"]["frame_id"].as<std::string>(), "cam_front/optical");
    EXPECT_EQ(y["child_frame_id"].as<std::string>(), "lidar_roof");
    const YAML::Node t = y["transform"]["translation"];
    const YAML::Node q = y["transform"]["rotation"];
    EXPECT_GE(q["w"].as<double>(), 0.0);
    ExpectSamePose(FromXyzQuat(t["x"].as<double>(), t["y"].as<double>(), t["z"].as<double>(),
                               q["x"].as<double>(), q["y"].as<double>(), q["z"].as<double>(),
                               q["w"].as<double>()),
                   T, "tf yaml");
  }
}

// Autoware's convention, checked with rotations built here from the axes (not with calibd's own
// RotationFromRpy): R = Rz(yaw) Ry(pitch) Rx(roll), i.e. tf2's setRPY.
TEST(CalibrationExportTest, AutowareYamlRpyReproducesTheRotation) {
  for (const Pose& T : TestPoses()) {
    const YAML::Node y = YAML::Load(FormatAutowareSensorKitYaml(Export(T)));
    ASSERT_TRUE(y.IsMap());
    EXPECT_EQ(y.size(), 1u);
    const YAML::Node child = y["cam_front/optical"]["lidar_roof"];
    ASSERT_TRUE(child.IsMap()) << FormatAutowareSensorKitYaml(Export(T));
    const double roll = child["roll"].as<double>(), pitch = child["pitch"].as<double>(),
                 yaw = child["yaw"].as<double>();
    EXPECT_LE(std::abs(pitch), M_PI / 2 + 1e-12);
    const double cr = std::cos(roll), sr = std::sin(roll), cp = std::cos(pitch),
                 sp = std::sin(pitch), cy = std::cos(yaw), sy = std::sin(yaw);
    Eigen::Matrix3d Rx, Ry, Rz;
    Rx << 1, 0, 0, 0, cr, -sr, 0, sr, cr;
    Ry << cp, 0, sp, 0, 1, 0, -sp, 0, cp;
    Rz << cy, -sy, 0, sy, cy, 0, 0, 0, 1;
    Pose read = Pose::Identity();
    read.linear() = Rz * Ry * Rx;
    read.translation() << child["x"].as<double>(), child["y"].as<double>(), child["z"].as<double>();
    ExpectSamePose(read, T, "autoware yaml");
  }
}

TEST(CalibrationExportTest, KittiVeloToCamReadsBack) {
  for (const Pose& T : TestPoses()) {
    const std::string text = FormatKittiVeloToCam(Export(T));
    std::map<std::string, std::string> fields;
    for (const std::string& line : Lines(text)) {
      const size_t colon = line.find(": ");
      ASSERT_NE(colon, std::string::npos) << line;
      fields[line.substr(0, colon)] = line.substr(colon + 2);
    }
    ASSERT_EQ(fields.size(), 5u) << text;
    EXPECT_EQ(fields.at("calib_time"), "15-Mar-2012 11:37:16");
    const auto r = Words(fields.at("R")), t = Words(fields.at("T"));
    ASSERT_EQ(r.size(), 9u);
    ASSERT_EQ(t.size(), 3u);
    EXPECT_EQ(Words(fields.at("delta_f")).size(), 2u);
    EXPECT_EQ(Words(fields.at("delta_c")).size(), 2u);
    Pose read = Pose::Identity();
    for (int i = 0; i < 9; ++i) read.linear()(i / 3, i % 3) = std::stod(r[i]);  // row-major
    for (int i = 0; i < 3; ++i) read.translation()(i) = std::stod(t[i]);
    ExpectSamePose(read, T, "kitti");
  }
}

TEST(CalibrationExportTest, WritesEveryFileIntoTheDirectory) {
  testing::TempDir dir;
  const CalibrationExport e = Export(ForwardCamera());
  std::string error;
  ASSERT_TRUE(WriteCalibrationExports(dir.file("export"), e, &error)) << error;
  using F = ExportFileNames;
  const std::pair<const char*, std::string> expected[] = {
      {F::kJson, FormatExportJson(e)},
      {F::kOpenCv, FormatOpenCvYaml(e)},
      {F::kRos, FormatRosStaticTransformFile(e)},
      {F::kTf, FormatTfYaml(e)},
      {F::kAutoware, FormatAutowareSensorKitYaml(e)},
      {F::kKitti, FormatKittiVeloToCam(e)}};
  for (const auto& [name, text] : expected) {
    std::string read;
    ASSERT_TRUE(ReadWholeFile(dir.file("export/") + name, &read, &error)) << error;
    EXPECT_EQ(read, text) << name;
  }
  // cv::FileStorage reads the file too (not only the text in memory).
  cv::FileStorage fs(dir.file("export/") + F::kOpenCv, cv::FileStorage::READ);
  ASSERT_TRUE(fs.isOpened());
  cv::Mat m;
  fs["T_camera_lidar"] >> m;
  ExpectSamePose(PoseFromMatrix(ToEigen(m)), e.T_camera_lidar, "opencv file");
  // Written again over the old files: same result.
  ASSERT_TRUE(WriteCalibrationExports(dir.file("export"), e, &error)) << error;
  // A directory whose parent is missing is an error naming it.
  EXPECT_FALSE(WriteCalibrationExports(dir.file("missing/export"), e, &error));
  EXPECT_NE(error.find("missing/export"), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
