// The agent's side of the diagnostic interfaces: uds::UdsBackend over the session
// machine and the calibration store, the DTC test results, and what the status frame and the
// lamp show. The protocol itself (sessions, security, NRCs) is the UDS server's.

#include <algorithm>
#include <cmath>
#include <cstring>
#include <ctime>

#include "calibd/agent/agent.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "clock.hpp"

namespace calibd {

namespace {

uds::ExtrinsicFigures Figures(const StoredCalibration* c) {
  uds::ExtrinsicFigures e;
  if (c == nullptr) return e;
  e.available = true;
  const Eigen::Vector3d t = c->T_camera_lidar.translation();
  const Eigen::Vector3d rpy = RpyFromRotation(c->T_camera_lidar.linear()) * kRad2Deg;
  e.x_m = t.x();
  e.y_m = t.y();
  e.z_m = t.z();
  e.roll_deg = rpy.x();
  e.pitch_deg = rpy.y();
  e.yaw_deg = rpy.z();
  return e;
}

// The verdict as the routine results record (routines.hpp) and the status frame
// (status_frame.hpp, deploy/calibd.dbc) code it: both name the same three verdicts.
template <typename WireVerdict>
WireVerdict VerdictCode(CalibrationOutcome::Verdict verdict) {
  switch (verdict) {
    case CalibrationOutcome::Verdict::kVerified:
      return WireVerdict::kVerified;
    case CalibrationOutcome::Verdict::kUpdated:
      return WireVerdict::kUpdated;
    case CalibrationOutcome::Verdict::kRejected:
      break;
  }
  return WireVerdict::kRejected;
}

}  // namespace

uds::RoutineConditions Agent::Conditions() const {
  uds::RoutineConditions c;
  const int64_t now = MonotonicUs();
  c.interlock_asserted = diag_.Interlock();
  c.lidar_alive = sensors_.Alive(SensorStream::kLidar, now);
  c.camera_alive = sensors_.Alive(SensorStream::kCamera, now);
  return c;
}

uds::BackendReply Agent::StartCalibration(const uds::CalibrateOptions& options) {
  StartRequest r;
  r.mode =
      options.mode == uds::CalibrationMode::kStatic ? SessionMode::kStatic : SessionMode::kMoving;
  r.max_duration_us = static_cast<int64_t>(options.max_duration_s) * 1000000;
  r.verify_only = options.verify_only;
  r.requester = options.verify_only ? "uds verify" : "uds calibrate";
  return Start(r).accepted ? uds::BackendReply::kAccepted
                           : uds::BackendReply::kConditionsNotCorrect;
}

uds::BackendReply Agent::StopCalibration() {
  const RequestReply reply = machine_.Stop(MonotonicUs());
  if (!reply.accepted) return uds::BackendReply::kSequenceError;
  Log("session " + std::to_string(machine_.session()) + " stopped over UDS");
  return uds::BackendReply::kAccepted;
}

void Agent::AbortCalibration() {
  if (machine_.Stop(MonotonicUs(), Reason::kSessionEnded).accepted)
    Log("session " + std::to_string(machine_.session()) +
        " aborted: the extended diagnostic session ended");
}

uds::RoutineSnapshot Agent::CalibrationStatus() const {
  uds::RoutineSnapshot r;
  const SessionState s = machine_.state();
  r.reason = machine_.reason();
  switch (s) {
    case SessionState::kIdle:
      r.status = uds::RoutineStatus::kIdle;
      break;
    case SessionState::kCollecting:
    case SessionState::kSolving:
      r.status = uds::RoutineStatus::kActive;
      r.progress_percent = static_cast<uint8_t>(std::lround(
          std::clamp(machine_.progress(), 0.0, 1.0) * (s == SessionState::kSolving ? 99.0 : 95.0)));
      break;
    case SessionState::kDone:
      r.status = uds::RoutineStatus::kSuccess;
      r.progress_percent = 100;
      break;
    case SessionState::kFailed:
      r.status = uds::RoutineStatus::kFailed;
      r.progress_percent = 100;
      break;
    case SessionState::kAborted:
      r.status = uds::RoutineStatus::kAborted;
      break;
  }
  const CalibrationOutcome* outcome = solve_.outcome();
  if (s == SessionState::kDone && outcome != nullptr) {
    r.verdict = VerdictCode<uds::RoutineVerdict>(outcome->verdict);
    // A failed commit is the news (store write failed) until a commit goes through.
    r.reason = machine_.commit_failed() ? machine_.reason() : outcome->reason;
    if (outcome->solved) {
      r.delta_rotation_deg = outcome->delta_rotation_deg;
      r.delta_translation_m = outcome->delta_translation_m;
    }
  }
  return r;
}

uds::BackendReply Agent::RestoreReference() {
  if (store_.reference() == nullptr) {
    last_error_ = "restore refused: the store holds no reference calibration";
    Log(last_error_);
    return uds::BackendReply::kConditionsNotCorrect;
  }
  std::string error;
  if (!store_.RestoreReference(WallUs() / 1000000, &error)) {
    last_error_ = "restore failed: " + error;
    Log(last_error_ + " (the previous calibration stays in use)");
    // A reference for other sensors is refused before anything is written: not a storage fault.
    const StoredCalibration* current = store_.current();
    const StoredCalibration* reference = store_.reference();
    const bool other_sensors =
        current != nullptr && (reference->lidar_serial != current->lidar_serial ||
                               reference->camera_serial != current->camera_serial);
    if (!other_sensors) diag_.Report(uds::Dtc::kStoreWriteFailed, true);
    return uds::BackendReply::kFailure;
  }
  CalibrationStored();
  Log("restored the reference calibration as version " + std::to_string(store_.current()->version));
  WriteExports();
  return uds::BackendReply::kAccepted;
}

uds::BackendReply Agent::StoreReference() {
  const StoredCalibration* current = store_.current();
  if (current == nullptr) {
    last_error_ = "store-reference refused: the store holds no current calibration";
    Log(last_error_);
    return uds::BackendReply::kConditionsNotCorrect;
  }
  const StoredCalibration kept = *current;  // the store's own copy changes as it writes
  std::string error;
  if (!store_.SetReference(kept, &error)) {
    last_error_ = "store-reference failed: " + error;
    Log(last_error_ + " (the previous reference stays)");
    diag_.Report(uds::Dtc::kStoreWriteFailed, true);
    return uds::BackendReply::kFailure;
  }
  diag_.Report(uds::Dtc::kStoreWriteFailed, false);
  Log("stored calibration version " + std::to_string(kept.version) + " as the reference (version " +
      std::to_string(store_.reference()->version) + ")");
  return uds::BackendReply::kAccepted;
}

bool Agent::WriteVin(std::string_view vin) {
  std::string error;
  if (!WriteFileAtomic(config_.uds.state_dir + "/vin", vin, &error)) {
    Log("VIN not stored: " + error);
    return false;
  }
  vin_.assign(vin);
  Log("VIN written over UDS: " + vin_);
  return true;
}

int64_t Agent::CalibrationUnixS() const {
  return store_.current() == nullptr ? 0 : store_.current()->created_unix_s;
}

uds::ExtrinsicFigures Agent::CurrentExtrinsic() const { return Figures(store_.current()); }
uds::ExtrinsicFigures Agent::ReferenceExtrinsic() const { return Figures(store_.reference()); }

uds::QualityFigures Agent::Quality() const {
  uds::QualityFigures q;
  const StoredCalibration* c = store_.current();
  if (c == nullptr) return q;
  q.reprojection_mean_px = c->reprojection_mean_px;
  q.residual_rms_m = c->residual_rms_m;
  q.rotation_sigma_deg = c->rotation_sigma_deg;
  q.translation_sigma_m = c->translation_sigma_m;
  q.rotation_bound_deg = c->rotation_bound_deg;
  q.translation_bound_m = c->translation_bound_m;
  q.frames_used = c->frames_used;
  q.boards_used = c->boards_used;
  return q;
}

std::string_view Agent::LidarSerial() const {
  const std::string& seen = sensors_.serial(SensorStream::kLidar);
  if (!seen.empty() || store_.current() == nullptr) return seen;
  return store_.current()->lidar_serial;
}

std::string_view Agent::CameraSerial() const {
  const std::string& seen = sensors_.serial(SensorStream::kCamera);
  if (!seen.empty() || store_.current() == nullptr) return seen;
  return store_.current()->camera_serial;
}

uds::CalibrationState Agent::State() const {
  if (store_.current() == nullptr) return uds::CalibrationState::kNotPerformed;
  if (sensors_.mismatch()) return uds::CalibrationState::kRecalibrationRequired;
  return uds::CalibrationState::kValid;
}

void Agent::ReportDtcs(int64_t now_us) {
  if (!config_.can_enabled) return;
  // Sensor data timeouts are tested while a session collects (the agent needs the data then).
  sensors_.CheckTimeouts(machine_.state() == SessionState::kCollecting, machine_.started_us(),
                         now_us, [this](SensorStream sensor, bool timed_out) {
                           const bool lidar = sensor == SensorStream::kLidar;
                           diag_.Report(lidar ? uds::Dtc::kLidarTimeout : uds::Dtc::kCameraTimeout,
                                        timed_out);
                           if (timed_out)
                             Log(std::string(lidar ? "LiDAR" : "camera") +
                                 " data timeout: no frame for more than 1 s while collecting");
                         });
}

DiagnosticsView Agent::DiagnosticsNow() const {
  DiagnosticsView v;
  StatusFrame& f = v.status;
  const SessionState s = machine_.state();
  switch (s) {
    case SessionState::kIdle:
      f.state = StatusFrame::State::kIdle;
      v.lamp = LampState::kIdle;
      break;
    case SessionState::kCollecting:
      f.state = StatusFrame::State::kCollecting;
      v.lamp = LampState::kRunning;
      break;
    case SessionState::kSolving:
      f.state = StatusFrame::State::kSolving;
      v.lamp = LampState::kRunning;
      break;
    case SessionState::kDone:
      f.state = StatusFrame::State::kDone;
      v.lamp = machine_.verdict() == CalibrationOutcome::Verdict::kRejected ? LampState::kFailure
                                                                            : LampState::kSuccess;
      break;
    case SessionState::kFailed:
      f.state = StatusFrame::State::kFailed;
      v.lamp = LampState::kFailure;
      break;
    case SessionState::kAborted:
      f.state = StatusFrame::State::kAborted;
      v.lamp = LampState::kFailure;
      break;
  }
  if (machine_.session() > 0)
    f.progress_percent = static_cast<int>(std::lround(
        std::clamp(s == SessionState::kCollecting ? machine_.progress() : 1.0, 0.0, 1.0) * 100.0));
  if (const CalibrationOutcome* outcome = solve_.outcome()) {
    f.last_verdict = VerdictCode<StatusFrame::Verdict>(outcome->verdict);
    if (outcome->solved) f.rotation_delta_deg = outcome->delta_rotation_deg;
  }
  switch (State()) {
    case uds::CalibrationState::kValid:
      f.calibration = StatusFrame::Calibration::kValid;
      break;
    case uds::CalibrationState::kNotPerformed:
      f.calibration = StatusFrame::Calibration::kNotPerformed;
      break;
    case uds::CalibrationState::kRecalibrationRequired:
      f.calibration = StatusFrame::Calibration::kRecalibrationRequired;
      break;
  }
  if (const StoredCalibration* c = store_.current()) {
    const int64_t since = std::max(c->created_unix_s, c->verified_unix_s);
    f.calibration_age_h =
        std::max<double>(0.0, static_cast<double>(WallUs() / 1000000 - since)) / 3600.0;
  }
  return v;
}

}  // namespace calibd
