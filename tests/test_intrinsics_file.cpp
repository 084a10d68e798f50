// Intrinsics files: the config's camera written as OpenCV FileStorage YAML (by cv::FileStorage),
// as a ROS camera_info YAML and as JSON reads back equal; bad files name the key.

#include "calibd/drivers/intrinsics_file.hpp"

#include <gtest/gtest.h>

#include <iomanip>
#include <opencv2/core.hpp>
#include <sstream>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"

namespace calibd {
namespace {

CameraIntrinsics ConfigCamera() {
  CameraIntrinsics c;  // the simulator's camera: 3840x1920, radial-tangential
  c.fx = 3325.25;
  c.fy = 3324.75;
  c.cx = 1919.5;
  c.cy = 960.125;
  return c;
}

std::string Num(double v) {
  std::ostringstream o;
  o << std::setprecision(17) << v;
  return o.str();
}

std::vector<double> Dist(const CameraIntrinsics& c) {
  if (c.model == DistortionModel::kKannalaBrandt) return {c.k1, c.k2, c.k3, c.k4};
  return {c.k1, c.k2, c.p1, c.p2, c.k3};
}

std::string List(const std::vector<double>& v) {
  std::string s = "[";
  for (size_t i = 0; i < v.size(); ++i) s += (i ? ", " : "") + Num(v[i]);
  return s + "]";
}

std::string OpenCvYaml(const CameraIntrinsics& c, const char* k_key, const char* d_key) {
  cv::FileStorage fs(".yaml", cv::FileStorage::WRITE | cv::FileStorage::MEMORY);
  fs << "image_width" << c.width << "image_height" << c.height;
  const cv::Mat K = (cv::Mat_<double>(3, 3) << c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1);
  fs << k_key << K << d_key << cv::Mat(Dist(c)).t();
  if (c.model == DistortionModel::kKannalaBrandt)
    fs << "distortion_model"
       << "equidistant";
  return fs.releaseAndGetString();
}

std::string RosYaml(const CameraIntrinsics& c) {
  const bool kb = c.model == DistortionModel::kKannalaBrandt;
  return "image_width: " + std::to_string(c.width) + "\nimage_height: " + std::to_string(c.height) +
         "\ncamera_name: front\ncamera_matrix:\n  rows: 3\n  cols: 3\n  data: " +
         List({c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1}) +
         "\ndistortion_model: " + (kb ? "equidistant" : "plumb_bob") +
         "\ndistortion_coefficients:\n  rows: 1\n  cols: " + std::to_string(Dist(c).size()) +
         "\n  data: " + List(Dist(c)) +
         "\nrectification_matrix:\n  rows: 3\n  cols: 3\n  data: [1, 0, 0, 0, 1, 0, 0, 0, 1]\n"
         "projection_matrix:\n  rows: 3\n  cols: 4\n  data: [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0]\n";
}

std::string Json(const CameraIntrinsics& c, bool nested) {
  const std::string K =
      nested ? "[" + List({c.fx, 0, c.cx}) + ", " + List({0, c.fy, c.cy}) + ", [0, 0, 1]]"
             : List({c.fx, 0, c.cx, 0, c.fy, c.cy, 0, 0, 1});
  return "{\"K\": " + K + ", \"D\": " + List(Dist(c)) + ", \"width\": " + std::to_string(c.width) +
         ", \"height\": " + std::to_string(c.height) +
         (c.model == DistortionModel::kKannalaBrandt ? ", \"distortion_model\": \"equidistant\""
                                                     : "") +
         "}";
}

void ExpectEqual(const CameraIntrinsics& a, const CameraIntrinsics& b, const std::string& what) {
  EXPECT_EQ(a.width, b.width) << what;
  EXPECT_EQ(a.height, b.height) << what;
  EXPECT_EQ(a.fx, b.fx) << what;
  EXPECT_EQ(a.fy, b.fy) << what;
  EXPECT_EQ(a.cx, b.cx) << what;
  EXPECT_EQ(a.cy, b.cy) << what;
  EXPECT_EQ(a.model, b.model) << what;
  EXPECT_EQ(a.k1, b.k1) << what;
  EXPECT_EQ(a.k2, b.k2) << what;
  EXPECT_EQ(a.p1, b.p1) << what;
  EXPECT_EQ(a.p2, b.p2) << what;
  EXPECT_EQ(a.k3, b.k3) << what;
  EXPECT_EQ(a.k4, b.k4) << what;
}

TEST(IntrinsicsFileTest, EveryFormatReadsBackTheConfigsCamera) {
  // The config's own camera, through its YAML, is the reference.
  CalibConfig config;
  config.camera = ConfigCamera();
  std::string error;
  config.boards.resize(1);
  CalibConfig parsed;
  ASSERT_TRUE(ParseConfigYaml(ConfigToYaml(config), &parsed, &error)) << error;
  CameraIntrinsics kb = parsed.camera;
  kb.model = DistortionModel::kKannalaBrandt;
  kb.k1 = 0.02;
  kb.k2 = -0.005;
  kb.k3 = 0.001;
  kb.k4 = -0.0002;
  kb.p1 = kb.p2 = 0.0;
  for (const CameraIntrinsics& camera : {parsed.camera, kb}) {
    const std::vector<std::pair<std::string, std::string>> files = {
        {"opencv", OpenCvYaml(camera, "camera_matrix", "distortion_coefficients")},
        {"opencv K/D", OpenCvYaml(camera, "K", "D")},
        {"ros", RosYaml(camera)},
        {"ros with ---", "---\n" + RosYaml(camera)},
        {"json", Json(camera, false)},
        {"json 3x3", Json(camera, true)}};
    for (const auto& [what, text] : files) {
      CameraIntrinsics read;
      read.fx = 1.0;  // anything but the expected value
      ASSERT_TRUE(ParseIntrinsics(text, what, &read, &error)) << what << ": " << error << "\n"
                                                              << text;
      ExpectEqual(read, camera, what);
    }
  }
}

TEST(IntrinsicsFileTest, RationalPolynomialWithZeroRationalTermsIsRadTan) {
  const CameraIntrinsics c = ConfigCamera();
  std::string ros = RosYaml(c);
  ros.replace(ros.find("plumb_bob"), 9, "rational_polynomial");
  ros.replace(ros.find(List(Dist(c))), List(Dist(c)).size(),
              List({c.k1, c.k2, c.p1, c.p2, c.k3, 0, 0, 0}));
  ros.replace(ros.find("rows: 1\n  cols: 5"), 17, "rows: 1\n  cols: 8");
  CameraIntrinsics read;
  std::string error;
  ASSERT_TRUE(ParseIntrinsics(ros, "r.yaml", &read, &error)) << error;
  ExpectEqual(read, c, "rational");
  ros.replace(ros.find(", 0, 0, 0]"), 10, ", 0.1, 0, 0]");
  EXPECT_FALSE(ParseIntrinsics(ros, "r.yaml", &read, &error));
  EXPECT_NE(error.find("r.yaml: distortion_coefficients: coefficient 5 (rational k4) is not 0"),
            std::string::npos)
      << error;
}

std::string ErrorOf(const std::string& text) {
  CameraIntrinsics read;
  std::string error;
  EXPECT_FALSE(ParseIntrinsics(text, "cam.yaml", &read, &error)) << text;
  return error;
}

TEST(IntrinsicsFileTest, BadFilesNameTheKey) {
  const CameraIntrinsics c = ConfigCamera();
  const std::string ros = RosYaml(c);
  auto without = [&](const std::string& line) {
    std::string s = ros;
    const size_t at = s.find(line);
    EXPECT_NE(at, std::string::npos);
    s.erase(at, s.find('\n', at) + 1 - at);
    return s;
  };
  EXPECT_EQ(ErrorOf(without("image_width")),
            "cam.yaml: image_width: missing (the image size the intrinsics belong to)");
  EXPECT_EQ(ErrorOf(without("image_height")),
            "cam.yaml: image_height: missing (the image size the intrinsics belong to)");
  EXPECT_EQ(ErrorOf("image_width: 10\nimage_height: 10\nD: [0, 0, 0, 0]\n"),
            "cam.yaml: camera_matrix: missing (also accepted: K)");
  EXPECT_EQ(ErrorOf("{\"D\": [], \"width\": 10, \"height\": 10}"),
            "cam.yaml: K: missing (also accepted: camera_matrix)");
  std::string s = ros;
  s.replace(s.find("plumb_bob"), 9, "fov");
  EXPECT_NE(ErrorOf(s).find("cam.yaml: distortion_model: 'fov' is not supported"),
            std::string::npos);
  EXPECT_NE(ErrorOf("{\"K\": [1, 2, 3], \"D\": [], \"width\": 10, \"height\": 10}")
                .find("cam.yaml: K: must be 3x3 (9 numbers), got 3"),
            std::string::npos);
  EXPECT_NE(ErrorOf("{\"K\": [100, 1, 5, 0, 100, 5, 0, 0, 1], \"width\": 10, \"height\": 10}")
                .find("cam.yaml: K: must be [fx 0 cx; 0 fy cy; 0 0 1]"),
            std::string::npos);
  EXPECT_NE(ErrorOf("{\"K\": [100, 0, 5, 0, 100, 5, 0, 0, 1], \"D\": [1, 2, 3], \"width\": 10, "
                    "\"height\": 10}")
                .find("cam.yaml: D: must have 4, 5, 8, 12 or 14 numbers"),
            std::string::npos);
  EXPECT_NE(ErrorOf("{\"K\": [100, 0, 5, 0, 100, 5, 0, 0, 1], \"width\": \"ten\", \"height\": 10}")
                .find("cam.yaml: width: must be a number"),
            std::string::npos);
  EXPECT_NE(ErrorOf("{\"K\": [100, 0, 5,").find("cam.yaml: JSON syntax"), std::string::npos);
  EXPECT_NE(ErrorOf("camera_matrix: [1, 2\n").find("cam.yaml: YAML syntax"), std::string::npos);
  EXPECT_NE(ErrorOf("%YAML:1.0\n---\nimage_width: 10\nimage_height: 10\nK: [1, 0]\n")
                .find("cam.yaml: K: must be 3x3 (9 numbers), got 2"),
            std::string::npos);
  // A negative focal length passes the shape checks, not CameraIntrinsics::IsValid.
  EXPECT_NE(ErrorOf("{\"K\": [-100, 0, 5, 0, 100, 5, 0, 0, 1], \"width\": 10, \"height\": 10}")
                .find("cam.yaml: K: "),
            std::string::npos);
  CameraIntrinsics read;
  std::string error;
  EXPECT_FALSE(LoadIntrinsicsFile("/nonexistent/cam.yaml", &read, &error));
  EXPECT_NE(error.find("/nonexistent/cam.yaml"), std::string::npos);
}

// An input fuzz_intrinsics found (tests/fuzz/corpus/intrinsics/`name`, `size` bytes): refused
// with a message naming the file.
void ExpectCorpusFileRefused(const std::string& name, size_t size) {
  std::string text, error;
  ASSERT_TRUE(ReadWholeFile(
      std::string(CALIBD_SOURCE_DIR) + "/tests/fuzz/corpus/intrinsics/" + name, &text, &error))
      << error;
  ASSERT_EQ(text.size(), size);
  CameraIntrinsics intrinsics;
  EXPECT_FALSE(ParseIntrinsics(text, name, &intrinsics, &error));
  EXPECT_EQ(error.rfind(name + ": ", 0), 0u) << error;
}

// fuzz_intrinsics found OpenCV's YAML reader throwing std::length_error (not a cv::Exception) on
// this malformed %YAML file (tests/fuzz/corpus/intrinsics/crash-opencv-length-error): refused
// with a message naming the file, not a crash.
TEST(IntrinsicsFileTest, WhateverTheParserThrowsTheFileIsRefused) {
  ExpectCorpusFileRefused("crash-opencv-length-error", 284);
  CameraIntrinsics intrinsics;
  std::string error;

  // An !!opencv-matrix declaring 100000 x 100000: OpenCV would allocate 80 GB before reading
  // the data (fuzz_intrinsics ran out of memory); the size is checked first.
  const std::string huge =
      "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n"
      "   rows: 100000\n   cols: 100000\n   dt: d\n   data: [ 1., 2., 3. ]\n";
  EXPECT_FALSE(ParseIntrinsics(huge, "huge.yaml", &intrinsics, &error));
  EXPECT_NE(error.find("camera_matrix: a matrix needs rows and cols of 0-16"), std::string::npos)
      << error;
  // ... or fewer numbers than it declares.
  const std::string short_data =
      "%YAML:1.0\n---\nimage_width: 640\nimage_height: 480\ncamera_matrix: !!opencv-matrix\n"
      "   rows: 3\n   cols: 3\n   dt: d\n   data: [ 1., 2., 3. ]\n";
  EXPECT_FALSE(ParseIntrinsics(short_data, "short.yaml", &intrinsics, &error));
  EXPECT_NE(error.find("camera_matrix: a 3x3 matrix needs 9 numbers, got 3"), std::string::npos)
      << error;
}

// fuzz_intrinsics found OpenCV's YAML reader looping forever on this %YAML file
// (tests/fuzz/corpus/intrinsics/hang-opencv-yaml-parser: a key without its colon before an
// indented map): such files are read by yaml-cpp now, and refused at once.
TEST(IntrinsicsFileTest, AMalformedOpenCvFileIsRefusedNotHungOn) {
  ExpectCorpusFileRefused("hang-opencv-yaml-parser", 188);
}

}  // namespace
}  // namespace calibd
