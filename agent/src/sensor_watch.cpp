#include "calibd/agent/sensor_watch.hpp"

namespace calibd {

bool SensorWatch::Alive(SensorStream sensor, int64_t now_us) const {
  const int64_t last = Of(sensor).last_frame_us;
  return last > 0 && now_us - last <= kSensorAliveUs;
}

bool SensorWatch::OnSensorInfo(const sensor_info_t& msg, const StoredCalibration* current,
                               std::string* line) {
  const bool lidar = msg.kind == sensor_info_t::KIND_LIDAR && msg.sensor_id == lidar_id_;
  const bool camera = msg.kind == sensor_info_t::KIND_CAMERA && msg.sensor_id == camera_id_;
  if (!lidar && !camera) return false;
  std::string& serial = Of(lidar ? SensorStream::kLidar : SensorStream::kCamera).serial;
  if (serial == msg.serial_number) return false;
  serial = msg.serial_number;
  if (current == nullptr) return false;
  const std::string& stored = lidar ? current->lidar_serial : current->camera_serial;
  // "unknown": committed before any sensor_info was seen, nothing to compare with.
  if (serial.empty() || stored == "unknown" || serial == stored || mismatch_) return false;
  mismatch_ = true;
  *line = std::string(lidar ? "LiDAR" : "camera") + " serial " + serial +
          " differs from the stored calibration's " + stored + ": recalibration required";
  return true;
}

}  // namespace calibd
