#include "lidar_model_source.hpp"

#include <lcm/lcm-cpp.hpp>
#include <vector>

#include "calibd/channels.hpp"
#include "calibd/drivers/lcm_frames.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd::tools {

namespace {

// Malformed frames met while looking for the first ones: how many, and what was wrong with the
// first (named by its file, or its place in the log).
struct BadFrames {
  int count = 0;
  std::string first;
  void Add(const std::string& what) {
    if (count++ == 0) first = what;
  }
};

// The first `count` frames of `lidar_id` in an LCM log.
bool FramesFromLog(const std::string& path, const std::string& lidar_id, int count,
                   std::vector<lidar_frame_t>* frames, BadFrames* bad, std::string* error) {
  lcm::LogFile log(path, "r");
  if (!log.good()) {
    if (error) *error = "cannot open LCM log '" + path + "'";
    return false;
  }
  const std::string channel(channels::kLidar.name);
  const FrameLimits limits;
  while (static_cast<int>(frames->size()) < count) {
    const lcm::LogEvent* ev = log.readNextEvent();
    if (ev == nullptr) break;
    if (ev->channel != channel) continue;
    lidar_frame_t msg;
    if (msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
      bad->Add("event " + std::to_string(ev->eventnum) + ": not a lidar_frame_t");
      continue;
    }
    if (msg.lidar_id != lidar_id) continue;
    PointCloudView view;
    std::string why;
    if (!LidarFrameToView(msg, limits, &view, &why)) {
      bad->Add("event " + std::to_string(ev->eventnum) + ": " + why);
      continue;
    }
    frames->push_back(std::move(msg));
  }
  return true;
}

// The first `count` readable point clouds of a recorded folder, in delivery order.
bool FramesFromFolder(const std::string& dir, const std::string& lidar_id, int count,
                      std::vector<lidar_frame_t>* frames, BadFrames* bad, std::string* error) {
  RecordedFolder folder;
  if (!ScanRecordedFolder(dir, RecordedFolderOptions{}, &folder, error)) return false;
  for (const RecordedEntry& entry : folder.entries) {
    if (static_cast<int>(frames->size()) >= count) break;
    if (entry.sensor != RecordedEntry::Sensor::kLidar) continue;
    lidar_frame_t msg;
    std::string why;
    if (!LoadRecordedCloud(entry, lidar_id, &msg, nullptr, &why)) {
      bad->Add(why);
      continue;
    }
    frames->push_back(std::move(msg));
  }
  return true;
}

}  // namespace

bool LidarModelForSession(const SessionSource& source, const CalibConfig& config, LidarModel* model,
                          LidarResolutionEstimate* estimate, std::string* error) {
  LidarKind kind;
  if (!LidarKindFromName(config.lidar_model, &kind, error)) return false;
  *estimate = LidarResolutionEstimate{};
  if (kind != LidarKind::kGeneric) {
    *model = MakeLidarModel(kind);
    return true;
  }
  const GenericLidarConfig& generic = config.lidar_generic;
  if (generic.complete() || (source.log_path.empty() && source.folder_path.empty()))
    return MakeGenericLidarModel(generic, nullptr, model, error);
  // The first frames of the session's LiDAR, copied (the views point into the messages).
  std::vector<lidar_frame_t> frames;
  BadFrames bad;
  const bool read = source.folder_path.empty()
                        ? FramesFromLog(source.log_path, config.lidar_id, generic.estimation_frames,
                                        &frames, &bad, error)
                        : FramesFromFolder(source.folder_path, config.lidar_id,
                                           generic.estimation_frames, &frames, &bad, error);
  if (!read) return false;
  const FrameLimits limits;
  std::vector<PointCloudView> views(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    std::string why;
    LidarFrameToView(frames[i], limits, &views[i], &why);
  }
  *estimate = EstimateLidarResolution(views.data(), views.size());
  if (frames.empty())
    estimate->error = "the " + std::string(source.folder_path.empty() ? "log" : "folder") +
                      " has no usable LiDAR frame of '" + config.lidar_id + "'" +
                      (bad.count > 0 ? " (" + std::to_string(bad.count) +
                                           " malformed; the first: " + bad.first + ")"
                                     : "");
  return MakeGenericLidarModel(generic, estimate, model, error);
}

}  // namespace calibd::tools
