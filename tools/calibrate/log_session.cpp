#include "log_session.hpp"

#include <algorithm>
#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <optional>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/session/frame_pairing.hpp"
#include "calibd/drivers/frame_debug.hpp"
#include "calibd/drivers/lcm_frames.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd::tools {

namespace {
// Pairs frames by time and detects the boards of every pair: the part a log and a folder share.
class SessionBuilder {
 public:
  SessionBuilder(const CalibConfig& config, const LogReadOptions& options,
                 SessionObservations* session, LogReadStats* stats,
                 const std::function<void(int)>& progress, const std::vector<int>& keep,
                 std::vector<FramePairData>* kept)
      : config_(config),
        options_(options),
        session_(session),
        stats_(stats),
        progress_(progress),
        keep_(keep),
        kept_(kept) {}

  /// Builds the pairer and the detectors; false with `error` from the config.
  bool Init(std::string* error) {
    LidarKind kind;
    if (!LidarKindFromName(config_.lidar_model, &kind, error)) return false;
    const LidarModel model = options_.lidar_model ? *options_.lidar_model : MakeLidarModel(kind);
    FramePairingConfig pairing;
    pairing.pair_tolerance_us = options_.pair_tolerance_us;
    pairing.sweep_us = static_cast<int64_t>(1e6 / model.frame_rate_hz);
    if (!pairing.IsValid(error)) {
      if (error) *error = "frame pairing: " + *error;
      return false;
    }
    sweep_us_ = pairing.sweep_us;
    pairer_.emplace(pairing);
    // Detectors are built only when they will run (their references take a few hundred ms).
    if (options_.detect) {
      camera_detector_.emplace(options_.camera, config_.camera, config_.boards);
      LidarDetectorConfig lidar = options_.lidar;
      lidar.report_clusters = lidar.report_clusters || !options_.debug_dir.empty();
      lidar_detector_.emplace(lidar, model, config_.boards);
    }
    if (camera_detector_ && !camera_detector_->ok()) {
      if (error) *error = "camera detector: " + camera_detector_->error();
      return false;
    }
    if (lidar_detector_ && !lidar_detector_->ok()) {
      if (error) *error = "LiDAR detector: " + lidar_detector_->error();
      return false;
    }
    return true;
  }

  int64_t sweep_us() const { return sweep_us_; }

  void Reserve() {
    if (options_.detect)
      session_->Reserve(options_.max_frames, static_cast<int>(config_.boards.size()) + 4,
                        options_.lidar.max_board_points);
  }

  enum class Sensor { kCamera, kLidar };
  void Bad(Sensor sensor, const std::string& what) {
    if (stats_->bad_messages++ == 0) stats_->first_bad_message = what;
    const bool lidar = sensor == Sensor::kLidar;
    if ((lidar ? stats_->bad_lidar++ : stats_->bad_camera++) == 0)
      (lidar ? stats_->first_bad_lidar : stats_->first_bad_camera) = what;
  }

  void OnCamera(camera_frame_t&& msg) {
    if (msg.camera_id != config_.camera_id) return;
    if (!pairer_->OnCamera(msg.utime).accepted) return;  // out of order: counted by the pairer
    pending_ = std::move(msg);  // a frame it displaces is counted unpaired by the pairer
  }

  void OnLidar(const lidar_frame_t& lidar_msg) {
    if (lidar_msg.lidar_id != config_.lidar_id) return;
    // Unpaired or out of order: counted by the pairer; the pending camera frame keeps waiting.
    if (!pairer_->OnLidar(lidar_msg.utime).paired) return;
    ImageView view;
    PointCloudView cloud;
    std::string why;
    if (!CameraFrameToView(*pending_, limits_, &decoded_, &view, &why)) {
      Bad(Sensor::kCamera, why);
      pending_.reset();
      return;
    }
    if (!LidarFrameToView(lidar_msg, limits_, &cloud, &why)) {
      Bad(Sensor::kLidar, why);
      pending_.reset();
      return;
    }
    const int pair_index = stats_->pairs++;
    if (options_.detect) {
      auto t0 = std::chrono::steady_clock::now();
      // A folder paired by name stem has pseudo times 1 s apart (RecordedFolderOptions): beyond
      // the stream gap, so each of its images is searched whole.
      camera_detector_->Detect(view, &cd_, pending_->utime);
      stats_->camera_ms.push_back(MsSince(t0));
      t0 = std::chrono::steady_clock::now();
      lidar_detector_->Detect(cloud, &ld_);
      stats_->lidar_ms.push_back(MsSince(t0));
      if (!session_->AddFrame(cd_, ld_, config_.boards,
                              FrameTimes{pending_->utime, lidar_msg.utime}))
        ++stats_->frames_over_capacity;
      if (!options_.debug_dir.empty()) {
        DrawRangeImagePicture(*lidar_detector_, ld_, &picture_);
        const FrameDebugInput debug{
            pair_index, pending_->utime, lidar_msg.utime, static_cast<int>(cloud.size), &cd_,
            &ld_,       &picture_};
        std::string write_error;
        if (!WriteFrameDebug(options_.debug_dir, debug, &write_error) &&
            stats_->debug_write_failures++ == 0)
          stats_->first_debug_error = write_error;
      }
    }
    if (kept_ && std::find(keep_.begin(), keep_.end(), pair_index) != keep_.end()) {
      FramePairData d;
      d.pair_index = pair_index;
      cv::Mat(view.height, view.width, CV_8UC1, const_cast<uint8_t*>(view.data),
              static_cast<size_t>(view.stride))
          .copyTo(d.image);
      d.x.assign(cloud.x, cloud.x + cloud.size);
      d.y.assign(cloud.y, cloud.y + cloud.size);
      d.z.assign(cloud.z, cloud.z + cloud.size);
      kept_->push_back(std::move(d));
    }
    pending_.reset();
    if (progress_ && stats_->pairs % 20 == 0) progress_(stats_->pairs);
  }

  void Finish() {
    pairer_->Flush();
    const FramePairingCounters& counts = pairer_->counters();
    stats_->unpaired_camera = static_cast<int>(counts.unpaired_camera);
    stats_->unpaired_lidar = static_cast<int>(counts.unpaired_lidar);
    stats_->out_of_order = static_cast<int>(counts.out_of_order_camera + counts.out_of_order_lidar);
  }

 private:
  const CalibConfig& config_;
  const LogReadOptions& options_;
  SessionObservations* session_;
  LogReadStats* stats_;
  const std::function<void(int)>& progress_;
  const std::vector<int>& keep_;
  std::vector<FramePairData>* kept_;
  int64_t sweep_us_ = 100000;
  std::optional<FramePairer> pairer_;
  std::optional<CameraDetector> camera_detector_;
  std::optional<LidarDetector> lidar_detector_;
  const FrameLimits limits_;
  std::optional<camera_frame_t> pending_;  // the pairer's pending camera frame
  cv::Mat decoded_;
  CameraDetections cd_;
  LidarDetections ld_;
  RangeImagePicture picture_;  // --debug
};

}  // namespace

bool ReadSessionLog(const std::string& log_path, const CalibConfig& config,
                    const LogReadOptions& options, SessionObservations* session,
                    LogReadStats* stats, std::string* error,
                    const std::function<void(int)>& progress, const std::vector<int>& keep,
                    std::vector<FramePairData>* kept) {
  SessionBuilder builder(config, options, session, stats, progress, keep, kept);
  if (!builder.Init(error)) return false;
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    if (error) *error = "cannot open LCM log '" + log_path + "'";
    return false;
  }
  builder.Reserve();
  const std::string cam_channel(channels::kCamera.name), lidar_channel(channels::kLidar.name);
  lidar_frame_t lidar_msg;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == cam_channel) {
      ++stats->camera_frames;
      camera_frame_t msg;
      if (msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
        builder.Bad(SessionBuilder::Sensor::kCamera, "camera_frame_t does not decode");
        continue;
      }
      builder.OnCamera(std::move(msg));
    } else if (ev->channel == lidar_channel) {
      ++stats->lidar_frames;
      if (lidar_msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
        builder.Bad(SessionBuilder::Sensor::kLidar, "lidar_frame_t does not decode");
        continue;
      }
      builder.OnLidar(lidar_msg);
    }
  }
  builder.Finish();
  return true;
}

std::string NoPairsCause(const LogReadStats& stats, const CalibConfig& config, bool folder,
                         bool* lidar) {
  *lidar = false;
  if (stats.pairs > 0) return "";
  const std::string where = folder ? "this folder" : "this log";
  const std::string camera_source =
      folder ? "image (*.png, *.jpg)" : "message on " + std::string(channels::kCamera.name);
  const std::string lidar_source =
      folder ? "point cloud (*.pcd)" : "message on " + std::string(channels::kLidar.name);
  if (stats.camera_frames == 0 && stats.lidar_frames == 0)
    return "no frames in " + where + ": no " + camera_source + " and no " + lidar_source;
  if (stats.lidar_frames == 0 || stats.bad_lidar == stats.lidar_frames) {
    *lidar = true;
    if (stats.lidar_frames == 0) return "no LiDAR frames in " + where + ": no " + lidar_source;
    return "every one of the " + std::to_string(stats.lidar_frames) + " LiDAR frames of " + where +
           " is malformed; the first: " + stats.first_bad_lidar;
  }
  if (stats.camera_frames == 0) return "no camera frames in " + where + ": no " + camera_source;
  if (stats.bad_camera == stats.camera_frames)
    return "every one of the " + std::to_string(stats.camera_frames) + " camera frames of " +
           where + " is malformed; the first: " + stats.first_bad_camera;
  return "no camera frame paired with a LiDAR frame: " + std::to_string(stats.camera_frames) +
         " camera and " + std::to_string(stats.lidar_frames) + " LiDAR frames read, " +
         std::to_string(stats.unpaired_camera) + " and " + std::to_string(stats.unpaired_lidar) +
         " left unpaired; check camera.id '" + config.camera_id + "' and lidar.id '" +
         config.lidar_id + "' against the recording, and that the frames' times overlap";
}

bool ReadSessionFolder(const std::string& folder_path, const CalibConfig& config,
                       const LogReadOptions& options, SessionObservations* session,
                       LogReadStats* stats, std::string* error,
                       const std::function<void(int)>& progress, const std::vector<int>& keep,
                       std::vector<FramePairData>* kept) {
  SessionBuilder builder(config, options, session, stats, progress, keep, kept);
  if (!builder.Init(error)) return false;
  RecordedFolderOptions folder_options;
  folder_options.sweep_us = builder.sweep_us();
  RecordedFolder folder;
  if (!ScanRecordedFolder(folder_path, folder_options, &folder, error)) return false;
  stats->unmatched_clouds = folder.unmatched_clouds;
  stats->unmatched_images = folder.unmatched_images;
  stats->pseudo_times = !folder.timed;
  builder.Reserve();
  lidar_frame_t lidar_msg;
  PcdInfo info;
  std::string why;
  for (const RecordedEntry& entry : folder.entries) {
    if (entry.sensor == RecordedEntry::Sensor::kCamera) {
      ++stats->camera_frames;
      camera_frame_t msg;
      if (!LoadRecordedImage(entry, config.camera_id, false, &msg, &why)) {
        builder.Bad(SessionBuilder::Sensor::kCamera, why);
        continue;
      }
      builder.OnCamera(std::move(msg));
    } else {
      ++stats->lidar_frames;
      if (!LoadRecordedCloud(entry, config.lidar_id, &lidar_msg, &info, &why)) {
        builder.Bad(SessionBuilder::Sensor::kLidar, why);
        continue;
      }
      stats->nan_points_dropped += info.nan_dropped;
      if (info.trailing_bytes > 0 && stats->padded_clouds++ == 0)
        stats->first_padded_cloud =
            entry.path + " (" + std::to_string(info.trailing_bytes) + " bytes after its points)";
      builder.OnLidar(lidar_msg);
    }
  }
  builder.Finish();
  return true;
}

}  // namespace calibd::tools
