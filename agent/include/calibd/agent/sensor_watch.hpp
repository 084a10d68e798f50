#pragma once
/// \file
/// What the agent knows of its two sensors apart from their frames: when each last sent one (a
/// sensor is alive within kSensorAliveUs; silent longer while a session collects is a data
/// timeout, DTC 5A0187 / 5A0287), and their serial numbers from sensor_info_t, which tell a
/// replaced sensor: a serial other than the stored calibration's means recalibration required
/// until a calibration for the new sensors is committed or restored.

#include <algorithm>
#include <cstdint>
#include <string>
#include <utility>

#include "calibd/agent/session_machine.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/sensor_info_t.hpp"

namespace calibd {

/// A sensor counts as alive when its last frame arrived within this.
inline constexpr int64_t kSensorAliveUs = 1000000;

class SensorWatch {
 public:
  /// The sensors in use (CalibConfig's camera_id and lidar_id).
  SensorWatch(std::string camera_id, std::string lidar_id)
      : camera_id_(std::move(camera_id)), lidar_id_(std::move(lidar_id)) {}

  /// A frame of `sensor` arrived at `now_us` (monotonic).
  void FrameArrived(SensorStream sensor, int64_t now_us) { Of(sensor).last_frame_us = now_us; }
  /// Its last frame arrived within kSensorAliveUs of `now_us`.
  bool Alive(SensorStream sensor, int64_t now_us) const;

  /// A sensor_info message: keeps the serial of a sensor in use. True when it reveals a replaced
  /// sensor (a serial other than `current`'s, which is not "unknown") for the first time;
  /// `line` then says which.
  bool OnSensorInfo(const sensor_info_t& msg, const StoredCalibration* current, std::string* line);
  /// Recalibration required (a replaced sensor), until ClearMismatch (a calibration for the
  /// sensors in use was stored).
  bool mismatch() const { return mismatch_; }
  void ClearMismatch() { mismatch_ = false; }
  /// The serial sensor_info gave; empty before any.
  const std::string& serial(SensorStream sensor) const { return Of(sensor).serial; }

  /// The data-timeout test of both sensors at `now_us`: while `collecting` (since
  /// `collecting_since_us`) a sensor silent for more than kSensorAliveUs fails it, a frame
  /// arriving passes it again. Calls report(sensor, timed_out) on each change.
  template <typename Report>
  void CheckTimeouts(bool collecting, int64_t collecting_since_us, int64_t now_us,
                     Report&& report) {
    for (SensorStream s : {SensorStream::kLidar, SensorStream::kCamera}) {
      Sensor& sensor = Of(s);
      const int64_t reference = std::max(sensor.last_frame_us, collecting_since_us);
      const bool silent = collecting && now_us - reference > kSensorAliveUs;
      if (silent && !sensor.timed_out) {
        sensor.timed_out = true;
        report(s, true);
      } else if (Alive(s, now_us) && sensor.timed_out) {
        sensor.timed_out = false;
        report(s, false);
      }
    }
  }

 private:
  struct Sensor {
    std::string serial;
    int64_t last_frame_us = 0;  ///< monotonic; 0: none yet
    bool timed_out = false;     ///< the data-timeout test's last result
  };
  Sensor& Of(SensorStream s) { return s == SensorStream::kCamera ? camera_ : lidar_; }
  const Sensor& Of(SensorStream s) const { return s == SensorStream::kCamera ? camera_ : lidar_; }

  std::string camera_id_, lidar_id_;
  Sensor camera_, lidar_;
  bool mismatch_ = false;
};

}  // namespace calibd
