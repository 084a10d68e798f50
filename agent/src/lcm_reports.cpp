#include "calibd/agent/lcm_reports.hpp"

#include <algorithm>

#include "calibd/channels.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/drivers/can_link.hpp"
#include "clock.hpp"

namespace calibd {

namespace {

int8_t StatusState(SessionState s) {
  switch (s) {
    case SessionState::kIdle:
      return calibration_status_t::STATE_IDLE;
    case SessionState::kCollecting:
      return calibration_status_t::STATE_COLLECTING;
    case SessionState::kSolving:
      return calibration_status_t::STATE_SOLVING;
    case SessionState::kDone:
      return calibration_status_t::STATE_DONE;
    case SessionState::kFailed:
      return calibration_status_t::STATE_FAILED;
    case SessionState::kAborted:
      return calibration_status_t::STATE_ABORTED;
  }
  return calibration_status_t::STATE_IDLE;
}

int8_t ResultVerdict(CalibrationOutcome::Verdict v) {
  switch (v) {
    case CalibrationOutcome::Verdict::kVerified:
      return calibration_result_t::VERDICT_VERIFIED;
    case CalibrationOutcome::Verdict::kUpdated:
      return calibration_result_t::VERDICT_UPDATED;
    case CalibrationOutcome::Verdict::kRejected:
      return calibration_result_t::VERDICT_REJECTED;
  }
  return calibration_result_t::VERDICT_NONE;
}

}  // namespace

bool LcmReports::Open(LcmBus* input, const std::string& publish_url, bool replay, LogFn log,
                      std::string* error) {
  log_ = std::move(log);
  if (!publish_url.empty()) {
    if (!own_.Open(publish_url, error)) return false;
    out_ = &own_;
  } else {
    out_ = replay ? nullptr : input;
  }
  return true;
}

bool LcmReports::Due(double rate_hz, int64_t now_us, int64_t* last_us) {
  if (now_us - *last_us < static_cast<int64_t>(1e6 / rate_hz)) return false;
  *last_us = now_us;
  return true;
}

template <typename Msg>
void LcmReports::Publish(std::string_view channel, const Msg& msg) {
  std::string error;
  if (out_ != nullptr && !out_->Publish(channel, msg, &error)) log_(error);
}

void LcmReports::PublishStatus(const SessionMachine& machine, const CollectionFigures& figures,
                               const IntakeCounters& counters, const std::string& last_error) {
  calibration_status_t s;
  s.utime = WallUs();
  s.state = StatusState(machine.state());
  s.progress = static_cast<float>(machine.progress());
  s.frames_used = figures.frames_with_boards;
  s.boards_observed = figures.boards;
  s.frames_dropped = static_cast<int32_t>(counters.dropped_queue_full);
  if (machine.reason() != Reason::kNone)
    s.last_error = std::string(NameOf(machine.reason())) +
                   (machine.detail().empty() ? "" : ": " + machine.detail());
  else if (!last_error.empty())
    s.last_error = last_error;
  else
    s.last_error = counters.last_error;
  s.guidance = machine.guidance();
  Publish(channels::kStatus.name, s);
}

void LcmReports::PublishHealth(const HealthFacts& facts, const IntakeCounters& c,
                               Diagnostics& diag) {
  health_t h;
  h.utime = WallUs();
  h.software_version = std::string(facts.software_version);
  h.calibration_state = facts.calibration_state;
  const StoredCalibration* current = facts.current;
  h.calibration_age_s = current == nullptr ? 0
                                           : h.utime / 1000000 - std::max(current->created_unix_s,
                                                                          current->verified_unix_s);
  const CalibrationOutcome* o = facts.outcome;
  h.last_verdict = o != nullptr ? ResultVerdict(o->verdict) : calibration_result_t::VERDICT_NONE;
  h.last_reason = o != nullptr ? NameOf(o->reason) : "";
  h.last_delta_rotation_deg = o != nullptr ? o->delta_rotation_deg : 0.0;
  h.last_delta_translation_m = o != nullptr ? o->delta_translation_m : 0.0;
  h.last_reprojection_mean_px = o != nullptr ? o->quality.reprojection_mean_px : 0.0;
  // Frame rates over the last health period.
  const int64_t now = MonotonicUs();
  const double dt = rate_since_us_ > 0 ? static_cast<double>(now - rate_since_us_) * 1e-6 : 0.0;
  auto rate = [dt](int64_t frames, int64_t before) {
    return dt > 0.0 ? static_cast<float>(static_cast<double>(frames - before) / dt) : 0.f;
  };
  h.camera_rate_hz = rate(c.camera_frames, rate_camera_frames_);
  h.lidar_rate_hz = rate(c.lidar_frames, rate_lidar_frames_);
  rate_camera_frames_ = c.camera_frames;
  rate_lidar_frames_ = c.lidar_frames;
  rate_since_us_ = now;
  h.camera_frames_received = c.camera_frames;
  h.lidar_frames_received = c.lidar_frames;
  h.camera_frames_dropped = static_cast<int32_t>(c.dropped_queue_full);
  h.lidar_frames_dropped = static_cast<int32_t>(c.lidar_dropped_queue_full);
  h.camera_frames_missed = static_cast<int32_t>(c.camera_missed);
  h.lidar_frames_missed = static_cast<int32_t>(c.lidar_missed);
  h.camera_serial = std::string(facts.camera_serial);
  h.lidar_serial = std::string(facts.lidar_serial);
  // lcm-gen leaves scalars uninitialised: every field is set here.
  h.can_state = "off";
  h.can_link_losses = h.can_bus_off_events = 0;
  h.num_active_dtcs = 0;
  if (const CanLinkStatus* isotp = diag.isotp_status()) {
    const CanLinkStatus* raw = diag.raw_status();
    h.can_state = ToString(raw->state == CanLinkState::kBusOff ? raw->state : isotp->state);
    h.can_link_losses = static_cast<int32_t>(isotp->counters.link_losses);
    h.can_bus_off_events = static_cast<int32_t>(raw->counters.bus_off_events);
  }
  if (uds::UdsServer* server = diag.server()) {
    for (size_t i = 0; i < uds::kDtcCount; ++i)
      if (server->dtcs().status(i) & uds::kTestFailed)
        h.active_dtcs.push_back(static_cast<int32_t>(uds::kDtcNumbers[i]));
    h.num_active_dtcs = static_cast<int16_t>(h.active_dtcs.size());
  }
  Publish(channels::kHealth.name, h);
}

void LcmReports::PublishResult(const CalibrationOutcome& o, const CalibConfig& calib) {
  calibration_result_t r;
  r.utime = WallUs();
  r.camera_id = calib.camera_id;
  r.lidar_id = calib.lidar_id;
  r.verdict = ResultVerdict(o.verdict);
  r.reason = NameOf(o.reason);
  const Eigen::Matrix4d T = o.T_camera_lidar.matrix();
  for (int i = 0; i < 16; ++i) r.T_camera_lidar[i] = T(i / 4, i % 4);
  const Eigen::Vector3d t = o.T_camera_lidar.translation();
  for (int i = 0; i < 3; ++i) r.xyz_m[i] = t[i];
  const Eigen::Vector3d rpy = RpyFromRotation(o.T_camera_lidar.linear()) * kRad2Deg;
  for (int i = 0; i < 3; ++i) r.rpy_deg[i] = rpy[i];
  r.delta_rotation_deg = o.delta_rotation_deg;
  r.delta_translation_m = o.delta_translation_m;
  r.reprojection_mean_px = o.quality.reprojection_mean_px;
  r.reprojection_p95_px = o.quality.reprojection_p95_px;
  r.residual_rms_m = o.quality.residual_rms_m;
  r.frames_used = o.quality.frames_used;
  r.boards_used = o.quality.boards_used;
  r.min_information_eigenvalue = o.quality.min_information_eigenvalue;
  const bool bounded = o.quality.has_error_bound();
  r.rotation_bound_deg = bounded ? o.quality.rotation_bound_deg : -1.0;
  r.translation_bound_m = bounded ? o.quality.translation_bound_m : -1.0;
  Publish(channels::kResult.name, r);
}

}  // namespace calibd
