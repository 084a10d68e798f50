#include "run.hpp"

#include <sys/stat.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <iomanip>
#include <opencv2/imgcodecs.hpp>
#include <ostream>

#include "calibd/channels.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/drivers/lcm_log.hpp"
#include "calibd/drivers/pcd_writer.hpp"
#include "lcm_output.hpp"
#include "overlay.hpp"
#include "truth_json.hpp"

namespace calibd::sim {

namespace {

calibd::sensor_info_t SensorInfo(int8_t kind, int64_t utime, const std::string& id,
                                 const std::string& model, const std::string& serial) {
  calibd::sensor_info_t s;
  s.utime = utime;
  s.kind = kind;
  s.sensor_id = id;
  s.model = model;
  s.serial_number = serial;
  s.firmware_version = "sim-1";
  return s;
}

// One frame pair's events in the log, in time order: sensor info (`with_info`), the image at
// mid-exposure, the sweep when it completes.
bool WriteLogFrame(const SessionOptions& options, bool with_info, const FrameTruth& frame_truth,
                   const calibd::camera_frame_t& camera_msg, const calibd::lidar_frame_t& lidar_msg,
                   int64_t sweep_us, LcmLogWriter* log, std::string* error) {
  if (with_info) {
    const int64_t t = frame_truth.camera_utime - 1;
    if (!log->WriteMessage(std::string(channels::kSensorInfo.name), t,
                           SensorInfo(calibd::sensor_info_t::KIND_CAMERA, t, options.camera_id,
                                      "sim-3840x1920", options.camera_serial),
                           error) ||
        !log->WriteMessage(std::string(channels::kSensorInfo.name), t,
                           SensorInfo(calibd::sensor_info_t::KIND_LIDAR, t, options.lidar_id,
                                      options.lidar_model, options.lidar_serial),
                           error))
      return false;
  }
  return log->WriteMessage(std::string(channels::kCamera.name), frame_truth.camera_utime,
                           camera_msg, error) &&
         log->WriteMessage(std::string(channels::kLidar.name), frame_truth.lidar_utime + sweep_us,
                           lidar_msg, error);
}

// Frame k written into the folder: its cloud and image (a JPEG message's bytes as they are, a
// mono8 one as PNG), and their rows of frames.csv.
bool WriteFolderFrame(const std::string& dir, int k, const cv::Mat& image,
                      const calibd::camera_frame_t& camera, const calibd::lidar_frame_t& lidar,
                      bool with_ring, std::string* csv, std::string* error) {
  char stem[16];
  std::snprintf(stem, sizeof(stem), "%06d", k);
  const std::string cloud = std::string(stem) + ".pcd";
  const bool jpeg = camera.encoding == calibd::camera_frame_t::ENCODING_JPEG;
  const std::string picture = std::string(stem) + (jpeg ? ".jpg" : ".png");
  std::vector<uint8_t> png;
  if (!jpeg && !cv::imencode(".png", image, png)) {
    if (error) *error = dir + "/" + picture + ": cannot encode the image";
    return false;
  }
  const std::vector<uint8_t>& bytes = jpeg ? camera.data : png;
  if (!WriteFileAtomic(dir + "/" + picture, std::string(bytes.begin(), bytes.end()), error) ||
      !WriteFileAtomic(dir + "/" + cloud, PcdBinaryFile(lidar, with_ring), error))
    return false;
  *csv += std::to_string(lidar.utime) + ",lidar," + cloud + "\n" + std::to_string(camera.utime) +
          ",camera," + picture + "\n";
  return true;
}

}  // namespace

bool RunSimulation(const SessionOptions& options, const SimOutputs& outputs, SimSummary* summary,
                   std::ostream* progress, std::string* error) {
  if (outputs.log_path.empty() && outputs.folder_path.empty()) {
    if (error) *error = "--out FILE or --folder DIR is required";
    return false;
  }
  // Open the outputs first: a bad path fails at once, before the expensive set-up.
  LcmLogWriter log;
  if (!outputs.log_path.empty() && !log.Open(outputs.log_path, error)) return false;
  if (!outputs.folder_path.empty() && !CreateDirectories(outputs.folder_path, error)) {
    if (error) *error = "--folder: " + *error;
    return false;
  }
  std::string csv = "time_us,sensor,file\n";
  SessionSimulator session;
  if (!session.Init(options, error)) return false;
  const int n = session.num_frames();
  if (!outputs.overlay_path.empty() && (outputs.overlay_frame < 0 || outputs.overlay_frame >= n)) {
    if (error) *error = "--overlay-frame must be in [0, " + std::to_string(n - 1) + "]";
    return false;
  }
  TruthWriter truth(session);

  cv::Mat image;
  LidarScan scan;
  scan.Reserve(static_cast<size_t>(session.lidar_model().nominal_points_per_frame) + 1024);
  FrameTruth frame_truth;
  calibd::camera_frame_t camera_msg;
  calibd::lidar_frame_t lidar_msg;
  const int64_t sweep_us =
      static_cast<int64_t>(std::llround(1e6 / session.lidar_model().frame_rate_hz));
  const int info_every = std::max(
      1, static_cast<int>(std::lround(options.trajectory.rate_hz / channels::kSensorInfo.rate_hz)));
  const int8_t encoding = options.image_encoding == "jpeg" ? calibd::camera_frame_t::ENCODING_JPEG
                                                           : calibd::camera_frame_t::ENCODING_MONO8;
  summary->frames.clear();
  const auto t0 = std::chrono::steady_clock::now();

  for (int k = 0; k < n; ++k) {
    session.SimulateFrame(k, &image, &scan, &frame_truth);
    ToLidarMessage(scan, frame_truth.lidar_utime, options.lidar_id, &lidar_msg);
    if (!ToCameraMessage(image, frame_truth.camera_utime, options.camera_id, encoding,
                         options.jpeg_quality, &camera_msg)) {
      if (error) *error = "JPEG encoding of frame " + std::to_string(k) + " failed";
      return false;
    }
    if (!outputs.folder_path.empty() &&
        !WriteFolderFrame(outputs.folder_path, k, image, camera_msg, lidar_msg,
                          session.lidar_model().has_rings, &csv, error))
      return false;
    if (!outputs.log_path.empty() && !WriteLogFrame(options, k % info_every == 0, frame_truth,
                                                    camera_msg, lidar_msg, sweep_us, &log, error))
      return false;
    truth.AddFrame(frame_truth, static_cast<int>(scan.size()));

    SimFrameSummary fs;
    fs.time_s = static_cast<double>(frame_truth.camera_utime - options.start_utime) * 1e-6;
    fs.distance_m = -(frame_truth.T_world_vehicle * session.T_vehicle_lidar()).translation().x();
    fs.lidar_points = static_cast<int>(scan.size());
    for (const auto& b : frame_truth.boards) {
      fs.boards_in_camera += b.tag_in_image ? 1 : 0;
      fs.boards_in_lidar += b.lidar_point_indices.size() >= 10 ? 1 : 0;
      fs.board_points += static_cast<int>(b.lidar_point_indices.size());
    }
    summary->frames.push_back(fs);

    if (!outputs.overlay_path.empty() && k == outputs.overlay_frame) {
      cv::Mat bgr;
      viz::DrawLidarOverlay(
          ImageView{image.data, image.cols, image.rows, static_cast<int>(image.step[0])},
          PointCloudView{scan.x.data(), scan.y.data(), scan.z.data(), nullptr, scan.size(),
                         scan.time_offset_us.data()},
          session.T_camera_lidar(), session.camera_model(), outputs.overlay_scale, &bgr);
      if (!cv::imwrite(outputs.overlay_path, bgr)) {
        if (error) *error = "cannot write overlay picture '" + outputs.overlay_path + "'";
        return false;
      }
    }
    if (progress && (k + 1) % 10 == 0) {
      const double el = SecondsSince(t0);
      *progress << "calibd-sim: frame " << (k + 1) << "/" << n << "  (" << std::fixed
                << std::setprecision(1) << el << " s, eta " << el / (k + 1) * (n - k - 1) << " s)\n"
                << std::flush;
    }
  }
  if (!outputs.log_path.empty()) {
    if (!log.Close(error)) return false;
    summary->events_written = log.events_written();
    struct stat st {};
    summary->log_bytes = ::stat(outputs.log_path.c_str(), &st) == 0 ? st.st_size : 0;
  }
  if (!outputs.folder_path.empty() && !outputs.folder_without_times &&
      !WriteFileAtomic(outputs.folder_path + "/frames.csv", csv, error))
    return false;
  if (!outputs.truth_path.empty() && !truth.Save(outputs.truth_path, error)) return false;
  if (!outputs.config_path.empty() &&
      !SaveConfigFile(outputs.config_path, session.UserConfig(), error))
    return false;
  return true;
}

void PrintSummary(const SimSummary& s, int every, std::ostream& out) {
  out << " frame   t[s]  dist[m]  lidar pts  board pts  boards cam  boards lidar\n";
  for (size_t k = 0; k < s.frames.size(); ++k) {
    if (every > 1 && k % every != 0 && k + 1 != s.frames.size()) continue;
    const auto& f = s.frames[k];
    out << std::setw(6) << k << std::fixed << std::setprecision(1) << std::setw(7) << f.time_s
        << std::setw(9) << f.distance_m << std::setw(11) << f.lidar_points << std::setw(11)
        << f.board_points << std::setw(12) << f.boards_in_camera << std::setw(14)
        << f.boards_in_lidar << "\n";
  }
  if (s.frames.empty()) return;
  std::vector<int> pts;
  double cam = 0, lid = 0;
  for (const auto& f : s.frames) {
    pts.push_back(f.lidar_points);
    cam += f.boards_in_camera;
    lid += f.boards_in_lidar;
  }
  std::sort(pts.begin(), pts.end());
  const double nf = static_cast<double>(s.frames.size());
  out << "frames: " << s.frames.size() << " pairs, " << s.events_written << " LCM events, "
      << std::setprecision(1) << static_cast<double>(s.log_bytes) / 1e6 << " MB\n"
      << "LiDAR points per frame: median " << pts[pts.size() / 2] << " (min " << pts.front()
      << ", max " << pts.back() << ")\n"
      << std::setprecision(2) << "boards visible per frame: camera " << cam / nf << ", LiDAR "
      << lid / nf << " (mean)\n";
}

}  // namespace calibd::sim
