#include "session_detector.hpp"

#include <time.h>

#include <chrono>

#include "calibd/core/common/stopwatch.hpp"

namespace calibd::bench {

double ProcessCpuMs() {
  timespec ts{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e3 + static_cast<double>(ts.tv_nsec) * 1e-6;
}

sim::SessionOptions BenchSessionOptions(const std::string& lidar, unsigned long long seed,
                                        int frames) {
  sim::SessionOptions so;
  so.seed = seed;
  so.lidar_model = lidar;
  so.trajectory.duration_s = frames / so.trajectory.rate_hz;
  return so;
}

bool DetectedSession::Init(const sim::SessionOptions& options, std::string* error,
                           const LidarDetectorConfig& lidar, const LidarModel* model,
                           const std::function<void(CalibConfig*)>& edit_user,
                           bool lidar_detector_later) {
  if (!session_.Init(options, error)) return false;
  user_ = session_.UserConfig();
  if (edit_user) edit_user(&user_);
  lidar_config_ = lidar;
  lidar_model_ = model ? *model : session_.lidar_model();
  boards_ = edit_user ? user_.boards : session_.workshop().geometries;
  lidar_detector_.reset();
  std::string why;
  if (lidar_detector_later ? !LidarDetector::CheckInputs(lidar_config_, lidar_model_, boards_, &why)
                           : !BuildLidarDetector(&why)) {
    if (error) *error = "LiDAR detector: " + why;
    return false;
  }
  camera_detector_.emplace(CameraDetectorConfig{}, edit_user ? user_.camera : options.camera,
                           boards_);
  if (!camera_detector_->ok()) {
    if (error) *error = "camera detector: " + camera_detector_->error();
    return false;
  }
  return true;
}

bool DetectedSession::BuildLidarDetector(std::string* error) {
  if (!lidar_detector_) lidar_detector_.emplace(lidar_config_, lidar_model_, boards_);
  if (lidar_detector_->ok()) return true;
  if (error) *error = lidar_detector_->error();
  return false;
}

void DetectedSession::Detect(int k, bool with_camera, FrameDetections* out) {
  Simulate(k, with_camera, &frame_);
  DetectFrame(frame_, out);
}

void DetectedSession::Simulate(int k, bool with_camera, SimulatedFrame* frame, bool with_lidar) {
  frame->index = k;
  if (!with_camera) frame->image.release();
  if (!with_lidar) frame->scan.Clear();
  session_.SimulateFrame(k, with_camera ? &frame->image : nullptr,
                         with_lidar ? &frame->scan : nullptr, &frame->truth);
}

void DetectedSession::DetectFrame(const SimulatedFrame& frame, FrameDetections* out,
                                  const LidarDetections* same_lidar,
                                  const CameraDetections* same_camera) {
  DetectOnly(frame, same_lidar == nullptr, same_camera == nullptr, out);
  if (same_lidar) out->lidar = *same_lidar;
  if (same_camera && !frame.image.empty()) out->camera = *same_camera;
}

void DetectedSession::UseTagSearchMemo(TagSearchMemo* memo) {
  if (camera_detector_) camera_detector_->UseSearchMemo(memo);
}

void DetectedSession::DetectOnly(const SimulatedFrame& frame, bool lidar, bool camera,
                                 FrameDetections* out) {
  out->truth = frame.truth;
  out->lidar_ms = out->lidar_cpu_ms = out->camera_ms = out->camera_cpu_ms = 0.0;
  if (lidar) {
    BuildLidarDetector(nullptr);  // one that is not ok() clears out->lidar
    const sim::LidarScan& scan = frame.scan;
    const PointCloudView cloud{
        scan.x.data(), scan.y.data(),
        scan.z.data(), session_.lidar_model().has_rings ? scan.ring.data() : nullptr,
        scan.size(),   scan.time_offset_us.data()};
    const auto t0 = SteadyClock::now();
    const double c0 = ProcessCpuMs();
    lidar_detector_->Detect(cloud, &out->lidar);
    out->lidar_ms = MsSince(t0);
    out->lidar_cpu_ms = ProcessCpuMs() - c0;
  }
  if (!camera || frame.image.empty()) return;
  const cv::Mat& image = frame.image;
  const ImageView view{image.data, image.cols, image.rows, static_cast<int>(image.step[0])};
  const auto tc = SteadyClock::now();
  const double cc = ProcessCpuMs();
  camera_detector_->Detect(view, &out->camera, out->truth.camera_utime);
  out->camera_ms = MsSince(tc);
  out->camera_cpu_ms = ProcessCpuMs() - cc;
}

}  // namespace calibd::bench
