// calibd-fuzz-seeds <corpus dir>: writes the seed corpora of the fuzz targets with the project's
// own encoders (lcm-gen's encode, tests/pcd_writer.hpp, CalibrationStore, OpenCV's JPEG/PNG
// writers, the UDS request bytes of the UDS suites). Run by hand when a format changes; the
// output is committed under tests/fuzz/corpus/ (README.md). Config and intrinsics seeds are text
// files copied or written by hand, not made here.

#include <cmath>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "calibd/calibration_request_t.hpp"
#include "calibd/camera_frame_t.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/lidar_reference_file.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "pcd_writer.hpp"

namespace fs = std::filesystem;

namespace {

fs::path root;

void Write(const std::string& target, const std::string& name, const std::string& bytes) {
  fs::create_directories(root / target);
  std::ofstream(root / target / name, std::ios::binary) << bytes;
}

template <typename Msg>
std::string Encode(const Msg& m) {
  std::string out(static_cast<size_t>(m.getEncodedSize()), '\0');
  m.encode(out.data(), 0, static_cast<int>(out.size()));
  return out;
}

cv::Mat Pattern(int w, int h) {
  cv::Mat img(h, w, CV_8UC1);
  for (int r = 0; r < h; ++r)
    for (int c = 0; c < w; ++c)
      img.at<uint8_t>(r, c) = static_cast<uint8_t>(((r / 4 + c / 4) % 2) * 200 + 20);
  return img;
}

std::string Jpeg(const cv::Mat& img) {
  std::vector<uint8_t> buf;
  cv::imencode(".jpg", img, buf, {cv::IMWRITE_JPEG_QUALITY, 70});
  return std::string(buf.begin(), buf.end());
}

std::string Png(const cv::Mat& img) {
  std::vector<uint8_t> buf;
  cv::imencode(".png", img, buf);
  return std::string(buf.begin(), buf.end());
}

void Camera() {
  using calibd::camera_frame_t;
  const cv::Mat grey = Pattern(16, 12);
  camera_frame_t m;
  m.utime = 1000000;
  m.camera_id = "front";
  m.width = 16;
  m.height = 12;
  m.stride = 16;
  m.encoding = camera_frame_t::ENCODING_MONO8;
  m.data.assign(grey.data, grey.data + grey.total());
  m.size = static_cast<int32_t>(m.data.size());
  Write("lcm_camera", "mono8_16x12", Encode(m));
  m.stride = 20;  // padded rows
  m.data.assign(static_cast<size_t>(20 * 12), 7);
  m.size = static_cast<int32_t>(m.data.size());
  Write("lcm_camera", "mono8_padded", Encode(m));
  cv::Mat bgr;
  cv::cvtColor(grey, bgr, cv::COLOR_GRAY2BGR);
  m.stride = 48;
  m.encoding = camera_frame_t::ENCODING_BGR8;
  m.data.assign(bgr.data, bgr.data + bgr.total() * 3);
  m.size = static_cast<int32_t>(m.data.size());
  Write("lcm_camera", "bgr8_16x12", Encode(m));
  const std::string jpg = Jpeg(grey);
  m.stride = 0;
  m.encoding = camera_frame_t::ENCODING_JPEG;
  m.data.assign(jpg.begin(), jpg.end());
  m.size = static_cast<int32_t>(m.data.size());
  Write("lcm_camera", "jpeg_16x12", Encode(m));
  Write("jpeg", "grey_16x12.jpg", jpg);
  Write("jpeg", "colour_24x8.jpg", Jpeg(cv::Mat(8, 24, CV_8UC3, cv::Scalar(10, 120, 240))));
  Write("recorded_image", "grey_16x12.jpg", jpg);
  Write("recorded_image", "grey_16x12.png", Png(grey));
  cv::Mat deep(6, 5, CV_16UC1, cv::Scalar(40000));
  Write("recorded_image", "deep_5x6.png", Png(deep));
  Write("recorded_image", "colour_5x6.png", Png(cv::Mat(6, 5, CV_8UC3, cv::Scalar(1, 2, 3))));
}

void Lidar() {
  calibd::lidar_frame_t m;
  m.utime = 1000000;
  m.lidar_id = "roof";
  // lcm-gen's encode takes &x[0] even for zero points (UB on an empty vector, UBSan stops it).
  for (auto* v : {&m.x, &m.y, &m.z, &m.intensity}) v->reserve(1);
  m.ring.reserve(1);
  m.time_offset_us.reserve(1);
  Write("lcm_lidar", "zero_points", Encode(m));
  m.num_points = 4;
  m.x = {1.0f, 2.0f, 3.0f, 4.0f};
  m.y = {0.5f, -0.5f, 0.0f, 1.0f};
  m.z = {0.1f, 0.2f, -0.3f, 0.0f};
  m.intensity = {10, 20, 30, 40};
  m.ring = {0, 1, 2, 3};
  m.time_offset_us = {0, 25000, 50000, 99000};
  Write("lcm_lidar", "four_points", Encode(m));
  m.ring = {-1, -1, -1, -1};
  m.x[1] = std::numeric_limits<float>::quiet_NaN();
  m.y[2] = std::numeric_limits<float>::infinity();
  Write("lcm_lidar", "no_rings_nan_inf", Encode(m));
}

void Requests() {
  using calibd::calibration_request_t;
  calibration_request_t m;
  m.utime = 1000000;
  m.requester = "tester";
  m.action = calibration_request_t::ACTION_START;
  m.mode = calibration_request_t::MODE_MOVING;
  Write("lcm_request", "start_moving", Encode(m));
  m.mode = calibration_request_t::MODE_STATIC;
  m.max_duration_ms = 30000;
  Write("lcm_request", "start_static_30s", Encode(m));
  m.action = calibration_request_t::ACTION_VERIFY;
  Write("lcm_request", "verify", Encode(m));
  m.action = calibration_request_t::ACTION_STOP;
  Write("lcm_request", "stop", Encode(m));
  m.action = calibration_request_t::ACTION_COMMIT;
  Write("lcm_request", "commit", Encode(m));
}

// Records of fuzz_uds.cpp: [flags][length][bytes]; length 0xFF sends the key for the last seed.
std::string Uds(const std::vector<std::vector<uint8_t>>& requests) {
  std::string out;
  for (const auto& r : requests) {
    out.push_back('\x02');  // 100 ms later, physically addressed
    out.push_back(static_cast<char>(r.size() == 1 && r[0] == 0xFF ? 0xFF : r.size()));
    if (!(r.size() == 1 && r[0] == 0xFF)) out.append(r.begin(), r.end());
  }
  return out;
}

void UdsRequests() {
  Write("uds", "session_tester_present", Uds({{0x10, 0x03}, {0x3E, 0x00}, {0x10, 0x01}}));
  Write("uds", "read_dids", Uds({{0x22, 0xF1, 0x90, 0xF1, 0x8C}, {0x22, 0xF1, 0x95}}));
  Write("uds", "read_dtcs",
        Uds({{0x19, 0x02, 0xFF}, {0x19, 0x01, 0x09}, {0x19, 0x0A}, {0x14, 0xFF, 0xFF, 0xFF}}));
  Write("uds", "unlock_start_routine",
        Uds({{0x10, 0x03},
             {0x27, 0x01},
             {0xFF},
             {0x31, 0x01, 0xF0, 0x00},
             {0x31, 0x03, 0xF0, 0x00},
             {0x31, 0x02, 0xF0, 0x00}}));
  Write("uds", "unlock_write_vin",
        Uds({{0x10, 0x03},
             {0x27, 0x01},
             {0xFF},
             {0x2E, 0xF1, 0x90, 'W', 'V', 'W', 'Z', 'Z', 'Z', '1',
              'K',  'Z',  'A',  'W', '0', '0', '0', '0', '0', '1'},
             {0x85, 0x02},
             {0x11, 0x01}}));
  Write("uds", "wrong_key",
        Uds({{0x10, 0x03},
             {0x27, 0x01},
             {0x27, 0x02, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15, 16}}));
}

void Pcds() {
  calibd::testing::PcdSpec s;
  s.fields = {{"x"}, {"y"}, {"z"}, {"intensity"}, {"ring", 'U', 2, 1}, {"time", 'F', 4, 1}};
  s.rows = {{1, 2, 3, 10, 0, 0.0}, {4, 5, 6, 20, 1, 0.01}, {7, 8, 9, 30, 2, 0.02}};
  for (const char* data : {"ascii", "binary", "binary_compressed"})
    Write("pcd", std::string("xyzirt_") + data + ".pcd", calibd::testing::WritePcd(s, data));
  calibd::testing::PcdSpec o;  // Ouster-like: integer ns times, padding, double xyz, organized
  o.fields = {
      {"x", 'F', 8, 1}, {"y", 'F', 8, 1}, {"z", 'F', 8, 1}, {"_", 'U', 1, 4}, {"t", 'U', 4, 1}};
  o.rows = {{1, 1, 1, 0, 0, 0, 0, 100}, {NAN, NAN, NAN, 0, 0, 0, 0, 200}};
  o.width = 1;
  o.height = 2;
  o.version = "0.6";
  Write("pcd", "ouster_binary.pcd", calibd::testing::WritePcd(o, "binary"));
}

void Store() {
  const fs::path dir = fs::temp_directory_path() / "calibd-fuzz-seeds-store";
  fs::remove_all(dir);
  calibd::CalibrationStore store;
  std::string error;
  calibd::CalibrationStoreConfig config;
  config.directory = dir.string();
  if (!store.Open(config, &error)) std::fprintf(stderr, "%s\n", error.c_str());
  calibd::StoredCalibration c;
  c.T_camera_lidar.translation() = Eigen::Vector3d(0.1, -0.2, 0.3);
  c.lidar_serial = "OT128-0042";
  c.camera_serial = "CAM-7";
  c.source = "workshop";
  c.verdict = "updated";
  c.created_unix_s = 1700000000;
  c.reprojection_mean_px = 0.8;
  c.frames_used = 120;
  c.boards_used = 300;
  if (!store.SetReference(c, &error) || !store.Commit(c, &error) || !store.Commit(c, &error))
    std::fprintf(stderr, "%s\n", error.c_str());
  for (const char* name : {"current.json", "reference.json"}) {
    std::ifstream in(dir / name, std::ios::binary);
    Write("calibration_store", name, std::string(std::istreambuf_iterator<char>(in), {}));
  }
  fs::remove_all(dir);
}

// The LiDAR reference cache: a small set, and the same with no views.
void References() {
  calibd::LidarReferenceSet set;
  set.key = 0x5eed5eed5eed5eedull;
  set.dims = 4;
  set.views = {0, 3};
  set.descriptors = {0.5f, -0.5f, 0.25f, -0.25f, 0.1f, 0.2f, -0.3f, 0.0f};
  Write("lidar_references", "two_views", calibd::EncodeReferenceSet(set));
  set.views.clear();
  set.descriptors.clear();
  Write("lidar_references", "no_views", calibd::EncodeReferenceSet(set));
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::fprintf(stderr, "usage: calibd-fuzz-seeds <corpus dir>\n");
    return 2;
  }
  root = argv[1];
  Camera();
  Lidar();
  Requests();
  UdsRequests();
  Pcds();
  Store();
  References();
  return 0;
}
