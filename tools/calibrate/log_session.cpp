#include "log_session.hpp"

#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <optional>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/frame_pairing.hpp"
#include "calibd/core/lidar_model.hpp"
#include "calibd/drivers/lcm_frames.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd::tools {

namespace {
double MsSince(std::chrono::steady_clock::time_point t0) {
  return std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
}
}  // namespace

bool ReadSessionLog(const std::string& log_path, const CalibConfig& config,
                    const LogReadOptions& options, SessionObservations* session,
                    LogReadStats* stats, std::string* error,
                    const std::function<void(int)>& progress, const std::vector<int>& keep,
                    std::vector<FramePairData>* kept) {
  LidarKind kind;
  if (!LidarKindFromName(config.lidar_model, &kind, error)) return false;
  const LidarModel model = MakeLidarModel(kind);
  FramePairingConfig pairing;
  pairing.pair_tolerance_us = options.pair_tolerance_us;
  pairing.sweep_us = static_cast<int64_t>(1e6 / model.frame_rate_hz);
  if (!pairing.IsValid(error)) {
    if (error) *error = "frame pairing: " + *error;
    return false;
  }
  // Detectors are built only when they will run (their references take a few hundred ms).
  std::optional<CameraDetector> camera_detector;
  std::optional<LidarDetector> lidar_detector;
  if (options.detect) {
    camera_detector.emplace(options.camera, config.camera, config.boards);
    lidar_detector.emplace(options.lidar, model, config.boards);
  }
  if (camera_detector && !camera_detector->ok()) {
    if (error) *error = "camera detector: " + camera_detector->error();
    return false;
  }
  if (lidar_detector && !lidar_detector->ok()) {
    if (error) *error = "LiDAR detector: " + lidar_detector->error();
    return false;
  }
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    if (error) *error = "cannot open LCM log '" + log_path + "'";
    return false;
  }
  if (options.detect)
    session->Reserve(options.max_frames, static_cast<int>(config.boards.size()) + 4,
                     options.lidar.max_board_points);

  const std::string cam_channel(channels::kCamera.name), lidar_channel(channels::kLidar.name);
  const FrameLimits limits;
  FramePairer pairer(pairing);
  std::optional<camera_frame_t> pending;  // the pairer's pending camera frame
  lidar_frame_t lidar_msg;
  cv::Mat decoded;
  CameraDetections cd;
  LidarDetections ld;
  auto bad = [&](const std::string& what) {
    if (stats->bad_messages++ == 0) stats->first_bad_message = what;
  };

  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == cam_channel) {
      ++stats->camera_frames;
      camera_frame_t msg;
      if (msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
        bad("camera_frame_t does not decode");
        continue;
      }
      if (msg.camera_id != config.camera_id) continue;
      if (!pairer.OnCamera(msg.utime).accepted) continue;  // out of order: counted by the pairer
      pending = std::move(msg);  // a frame it displaces is counted unpaired by the pairer
    } else if (ev->channel == lidar_channel) {
      ++stats->lidar_frames;
      if (lidar_msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
        bad("lidar_frame_t does not decode");
        continue;
      }
      if (lidar_msg.lidar_id != config.lidar_id) continue;
      // Unpaired or out of order: counted by the pairer; the pending camera frame keeps waiting.
      if (!pairer.OnLidar(lidar_msg.utime).paired) continue;
      ImageView view;
      PointCloudView cloud;
      std::string why;
      if (!CameraFrameToView(*pending, limits, &decoded, &view, &why) ||
          !LidarFrameToView(lidar_msg, limits, &cloud, &why)) {
        bad(why);
        pending.reset();
        continue;
      }
      const int pair_index = stats->pairs++;
      if (options.detect) {
        auto t0 = std::chrono::steady_clock::now();
        camera_detector->Detect(view, &cd);
        stats->camera_ms.push_back(MsSince(t0));
        t0 = std::chrono::steady_clock::now();
        lidar_detector->Detect(cloud, &ld);
        stats->lidar_ms.push_back(MsSince(t0));
        if (!session->AddFrame(cd, ld, config.boards, FrameTimes{pending->utime, lidar_msg.utime}))
          ++stats->frames_over_capacity;
      }
      if (kept && std::find(keep.begin(), keep.end(), pair_index) != keep.end()) {
        FramePairData d;
        d.pair_index = pair_index;
        cv::Mat(view.height, view.width, CV_8UC1, const_cast<uint8_t*>(view.data),
                static_cast<size_t>(view.stride))
            .copyTo(d.image);
        d.x.assign(cloud.x, cloud.x + cloud.size);
        d.y.assign(cloud.y, cloud.y + cloud.size);
        d.z.assign(cloud.z, cloud.z + cloud.size);
        kept->push_back(std::move(d));
      }
      pending.reset();
      if (progress && stats->pairs % 20 == 0) progress(stats->pairs);
    }
  }
  pairer.Flush();
  const FramePairingCounters& counts = pairer.counters();
  stats->unpaired_camera = static_cast<int>(counts.unpaired_camera);
  stats->unpaired_lidar = static_cast<int>(counts.unpaired_lidar);
  stats->out_of_order = static_cast<int>(counts.out_of_order_camera + counts.out_of_order_lidar);
  return true;
}

}  // namespace calibd::tools
