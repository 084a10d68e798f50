#pragma once
/// \file
/// The agent's reports on LCM (lcm_types/, channels.hpp): calibration_status_t and health_t at
/// their configured rates, calibration_result_t when a session's solve ends. Built from the
/// agent's parts; published on the input bus, on AgentOptions::publish_url, or nowhere (a
/// replayed log is not writable).

#include <cstdint>
#include <functional>
#include <string>
#include <string_view>

#include "calibd/agent/diagnostics.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/calibration_result_t.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/lcm_bus.hpp"
#include "calibd/health_t.hpp"

namespace calibd {

/// What health_t tells besides the intake's counters and the diagnostics.
struct HealthFacts {
  std::string_view software_version;
  int8_t calibration_state = health_t::CALIB_NOT_PERFORMED;  ///< health_t::CALIB_*
  const StoredCalibration* current = nullptr;                ///< the store's, null: none
  const CalibrationOutcome* outcome = nullptr;               ///< the last session's, null: none yet
  std::string_view camera_serial, lidar_serial;
};

class LcmReports {
 public:
  using LogFn = std::function<void(const std::string&)>;

  /// Publishes on `publish_url` when not empty (opened here), else on `input` unless `replay`.
  /// Publication errors go to `log`. False with `error` when publish_url cannot be opened.
  bool Open(LcmBus* input, const std::string& publish_url, bool replay, LogFn log,
            std::string* error);
  bool publishing() const { return out_ != nullptr; }

  /// True when a period of `rate_hz` has passed since `*last_us`, which it then sets to `now_us`.
  static bool Due(double rate_hz, int64_t now_us, int64_t* last_us);

  void PublishStatus(const SessionMachine& machine, const CollectionFigures& figures,
                     const IntakeCounters& counters, const std::string& last_error);
  /// Frame rates are measured over the time since the previous health message.
  void PublishHealth(const HealthFacts& facts, const IntakeCounters& counters, Diagnostics& diag);
  void PublishResult(const CalibrationOutcome& outcome, const CalibConfig& calib);

 private:
  template <typename Msg>
  void Publish(std::string_view channel, const Msg& msg);

  LcmBus own_;             ///< opened for a publish_url
  LcmBus* out_ = nullptr;  ///< the input bus, own_, or null
  LogFn log_;
  int64_t rate_camera_frames_ = 0, rate_lidar_frames_ = 0, rate_since_us_ = 0;
};

}  // namespace calibd
