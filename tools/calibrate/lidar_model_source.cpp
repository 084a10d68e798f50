#include "lidar_model_source.hpp"

#include <lcm/lcm-cpp.hpp>
#include <vector>

#include "calibd/channels.hpp"
#include "calibd/drivers/lcm_frames.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd::tools {

bool LidarModelForLog(const std::string& log_path, const CalibConfig& config, LidarModel* model,
                      LidarResolutionEstimate* estimate, std::string* error) {
  LidarKind kind;
  if (!LidarKindFromName(config.lidar_model, &kind, error)) return false;
  *estimate = LidarResolutionEstimate{};
  if (kind != LidarKind::kGeneric) {
    *model = MakeLidarModel(kind);
    return true;
  }
  const GenericLidarConfig& generic = config.lidar_generic;
  if (generic.complete() || log_path.empty())
    return MakeGenericLidarModel(generic, nullptr, model, error);
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    if (error) *error = "cannot open LCM log '" + log_path + "'";
    return false;
  }
  // The first frames of the session's LiDAR, copied (the views point into the messages).
  const std::string channel(channels::kLidar.name);
  const FrameLimits limits;
  std::vector<lidar_frame_t> frames;
  int bad = 0;
  while (static_cast<int>(frames.size()) < generic.estimation_frames) {
    const lcm::LogEvent* ev = log.readNextEvent();
    if (ev == nullptr) break;
    if (ev->channel != channel) continue;
    lidar_frame_t msg;
    if (msg.decode(ev->data, 0, static_cast<int>(ev->datalen)) < 0) {
      ++bad;
      continue;
    }
    if (msg.lidar_id != config.lidar_id) continue;
    PointCloudView view;
    std::string why;
    if (!LidarFrameToView(msg, limits, &view, &why)) {
      ++bad;
      continue;
    }
    frames.push_back(std::move(msg));
  }
  std::vector<PointCloudView> views(frames.size());
  for (size_t i = 0; i < frames.size(); ++i) {
    std::string why;
    LidarFrameToView(frames[i], limits, &views[i], &why);
  }
  *estimate = EstimateLidarResolution(views.data(), views.size());
  if (frames.empty())
    estimate->error = "the log has no usable LiDAR frame of '" + config.lidar_id + "'" +
                      (bad > 0 ? " (" + std::to_string(bad) + " malformed)" : "");
  return MakeGenericLidarModel(generic, estimate, model, error);
}

}  // namespace calibd::tools
