#include "calibd/agent/agent.hpp"

#include <poll.h>
#include <signal.h>
#include <sys/signalfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <iostream>

#include "calibd/agent/session_marker.hpp"
#include "calibd/agent/thread_nice.hpp"
#include "calibd/calibration_status_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/calibration_engine.hpp"
#include "calibd/core/lidar_model.hpp"
#include "calibd/core/lidar_resolution.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"
#include "calibd/drivers/can_link.hpp"
#include "clock.hpp"

namespace calibd {

namespace {

constexpr int kTickMs = 50;     ///< poll loop timer: status, health and time limits are checked
constexpr int kFrameQueue = 2;  ///< LCM messages waiting per sensor channel (udpm drops beyond)
/// LCM messages waiting on CALIBD_SENSOR_INFO and CALIBD_REQUEST (1 Hz and events, each read at
/// the next poll): room for bursts of several senders; beyond it udpm drops the newest.
constexpr int kEventQueue = 16;

// RAII for the poll loop's own descriptors.
struct Fd {
  int fd = -1;
  ~Fd() {
    if (fd >= 0) ::close(fd);
  }
};

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

bool Terminal(SessionState s) {
  return s == SessionState::kDone || s == SessionState::kFailed || s == SessionState::kAborted;
}

// SIGTERM and SIGINT: read from Run's signalfd, so blocked in every thread.
sigset_t StopSignals() {
  sigset_t signals;
  sigemptyset(&signals);
  sigaddset(&signals, SIGTERM);
  sigaddset(&signals, SIGINT);
  return signals;
}

}  // namespace

Agent::Agent(const AgentConfig& config) : config_(config), machine_(SessionConfigFrom(config)) {}

Agent::~Agent() {
  if (solver_.joinable()) solver_.join();
}

void Agent::Log(const std::string& line) const {
  if (!options_.quiet) std::cerr << "calibd-agent: " << line << std::endl;
}

void Agent::CheckInterruptedSession() {
  marker_path_ = SessionMarkerPath(config_.store.directory);
  SessionMarker marker;
  std::string error;
  const MarkerRead read = ReadSessionMarker(marker_path_, &marker, &error);
  if (read == MarkerRead::kNone) {
    RemoveSessionMarker(marker_path_, &error);  // a temp file of a write cut short, if any
    return;
  }
  std::string line;
  if (read == MarkerRead::kFound) {
    char started[32] = "an unknown time";
    const time_t t = static_cast<time_t>(marker.started_unix_s);
    tm utc{};
    if (gmtime_r(&t, &utc) != nullptr) std::strftime(started, sizeof(started), "%FT%TZ", &utc);
    line = "the previous run stopped during session " + std::to_string(marker.session) +
           " (started by '" + marker.trigger + "' at " + started + ")";
  } else {
    line = "the previous run stopped during a session (" + error + ")";
  }
  line += " without a result: aborted; the stored calibration is unchanged";
  Log(line);
  // In CALIBD_STATUS until a session starts (Start clears it).
  last_error_ = "session_interrupted: " + line;
  diag_.Report(uds::Dtc::kSessionInterrupted, true);
  if (!RemoveSessionMarker(marker_path_, &error)) Log("session marker: " + error);
}

bool Agent::CheckDetectorStartup() {
  const FrameIntake::Startup s = intake_.startup();
  if (s.failed) {
    Log(s.error + ": stopping");
    return false;
  }
  if (!s.ready) return true;
  detectors_ready_ = true;
  Log("LiDAR detector ready: " + std::to_string(s.references) + " reference descriptors in " +
      std::to_string(static_cast<int64_t>(s.build_ms)) + " ms (built at nice " +
      std::to_string(s.build_nice) + ")");
  return true;
}

void Agent::EndSessionMarker() {
  if (marker_session_ == 0) return;
  std::string error;
  if (!RemoveSessionMarker(marker_path_, &error)) Log("session marker: " + error);
  marker_session_ = 0;
}

bool Agent::Init(const AgentOptions& options, std::string* error) {
  options_ = options;
  // Blocked before the detector and LCM threads start, so that they inherit the mask: a stop
  // signal delivered to one of them would otherwise kill the process (default action) instead of
  // reaching Run's signalfd. One arriving during start-up waits, pending, for the loop.
  const sigset_t stop_signals = StopSignals();
  pthread_sigmask(SIG_BLOCK, &stop_signals, nullptr);
  if (!store_.Open(config_.store, error)) return false;
  for (const std::string& w : store_.load_warnings()) Log("store: " + w);
  if (store_.current() != nullptr)
    Log("stored calibration version " + std::to_string(store_.current()->version) + " (" +
        store_.current()->source + ")");
  else
    Log("no stored calibration: the config's prior is used");

  software_version_ = config_.SoftwareVersion();
  if (!diag_.Start(
          config_, this, [this](const std::string& line) { Log(line); }, MonotonicUs(), WallUs(),
          error))
    return false;
  if (config_.can_enabled) {
    std::string vin_error;
    if (!ReadWholeFile(config_.uds.state_dir + "/vin", &vin_, &vin_error)) vin_.clear();
    diag_.Report(uds::Dtc::kStoreCorrupt, !store_.load_warnings().empty());
    diag_.Report(uds::Dtc::kCalibrationNotPerformed, store_.current() == nullptr);
    Log("diagnostics: UDS on " + config_.isotp.interface + ", status frame " +
        CanIdText(config_.status_frame_id));
  }
  CheckInterruptedSession();
  if (!wake_.Open(error)) return false;
  intake_.SetReadyEvent(&wake_);
  IntakeConfig intake = IntakeConfigFrom(config_);
  if (!options.debug_dir.empty()) {
    if (!CreateDirectories(options.debug_dir, error)) {
      if (error) *error = "--debug: " + *error;
      return false;
    }
    intake.debug_dir = options.debug_dir;
  }
  if (!intake_.Init(intake, config_.calib, error)) return false;

  LidarModel lidar_model;
  if (!LidarModelFromConfig(config_.calib.lidar_model, config_.calib.lidar_generic, &lidar_model,
                            error))
    return false;
  projection_ = SessionProjection(lidar_model);
  recorder_.Init(config_);

  const std::string url = options.lcm_url.empty() ? config_.lcm_url : options.lcm_url;
  if (!bus_.Open(url, error)) return false;
  const bool ok = bus_.Subscribe<camera_frame_t>(
                      channels::kCamera.name, kFrameQueue,
                      [this](const camera_frame_t& m, int64_t) { OnCamera(m); }, error) &&
                  bus_.Subscribe<lidar_frame_t>(
                      channels::kLidar.name, kFrameQueue,
                      [this](const lidar_frame_t& m, int64_t) { OnLidar(m); }, error) &&
                  bus_.Subscribe<sensor_info_t>(
                      channels::kSensorInfo.name, kEventQueue,
                      [this](const sensor_info_t& m, int64_t) { OnSensorInfo(m); }, error) &&
                  bus_.Subscribe<calibration_request_t>(
                      channels::kRequest.name, kEventQueue,
                      [this](const calibration_request_t& m, int64_t) { OnRequest(m); }, error);
  if (!ok) return false;
  const bool replay = bus_.url().rfind("file://", 0) == 0;
  if (replay) {
    // A log is read at its own pace (and held back while the detectors catch up): the time
    // between its frames is not the sensors', so no sensor timeout (session_machine.hpp).
    SessionConfig session = SessionConfigFrom(config_);
    session.sensor_timeout_us = 0;
    machine_ = SessionMachine(session);
  }
  if (!options.publish_url.empty()) {
    if (!out_bus_.Open(options.publish_url, error)) return false;
    publisher_ = &out_bus_;
  } else if (!replay) {
    publisher_ = &bus_;
  } else {
    Log("replaying a log without --publish-url: status, health and results are not published");
  }
  Log("ready on " + bus_.url() + " (camera '" + config_.calib.camera_id + "', LiDAR '" +
      config_.calib.lidar_id + "' " + config_.calib.lidar_model + ")");
  if (options.calibrate_now) {
    StartRequest r;
    r.requester = "--calibrate-now";
    Start(r);
  }
  return true;
}

template <typename Msg>
void Agent::Publish(std::string_view channel, const Msg& msg) {
  std::string error;
  if (publisher_ != nullptr && !publisher_->Publish(channel, msg, &error)) Log(error);
}

void Agent::OnCamera(const camera_frame_t& msg) {
  last_camera_us_ = MonotonicUs();
  if (detectors_ready_ && msg.camera_id == config_.calib.camera_id)
    machine_.FrameArrived(SensorStream::kCamera, last_camera_us_);
  intake_.OnCamera(msg);
}
void Agent::OnLidar(const lidar_frame_t& msg) {
  last_lidar_us_ = MonotonicUs();
  if (detectors_ready_ && msg.lidar_id == config_.calib.lidar_id)
    machine_.FrameArrived(SensorStream::kLidar, last_lidar_us_);
  const int64_t pairs_formed = intake_.counters().pairs_formed;
  intake_.OnLidar(msg);
  if (intake_.counters().pairs_formed > pairs_formed) machine_.PairFormed(last_lidar_us_);
}

void Agent::OnSensorInfo(const sensor_info_t& msg) {
  const bool lidar =
      msg.kind == sensor_info_t::KIND_LIDAR && msg.sensor_id == config_.calib.lidar_id;
  const bool camera =
      msg.kind == sensor_info_t::KIND_CAMERA && msg.sensor_id == config_.calib.camera_id;
  if (!lidar && !camera) return;
  std::string& serial = lidar ? lidar_serial_ : camera_serial_;
  if (serial == msg.serial_number) return;
  serial = msg.serial_number;
  const StoredCalibration* current = store_.current();
  if (current == nullptr) return;
  const std::string& stored = lidar ? current->lidar_serial : current->camera_serial;
  // "unknown": committed before any sensor_info was seen, nothing to compare with.
  if (!serial.empty() && stored != "unknown" && serial != stored && !sensor_mismatch_) {
    sensor_mismatch_ = true;
    diag_.Report(uds::Dtc::kRecalibrationRequired, true);
    Log(std::string(lidar ? "LiDAR" : "camera") + " serial " + serial +
        " differs from the stored calibration's " + stored + ": recalibration required");
  }
}

void Agent::OnRequest(const calibration_request_t& msg) {
  Log("request " + std::to_string(msg.action) + " from '" + msg.requester + "'");
  if (msg.action == calibration_request_t::ACTION_START ||
      msg.action == calibration_request_t::ACTION_VERIFY) {
    StartRequest r;
    r.mode = msg.mode == calibration_request_t::MODE_STATIC ? SessionMode::kStatic
                                                            : SessionMode::kMoving;
    r.max_duration_us = static_cast<int64_t>(std::max(0, msg.max_duration_ms)) * 1000;
    r.verify_only = msg.action == calibration_request_t::ACTION_VERIFY;
    r.requester = msg.requester;
    Start(r);
  } else if (msg.action == calibration_request_t::ACTION_STOP) {
    const RequestReply reply = machine_.Stop(MonotonicUs());
    if (!reply.accepted) last_error_ = "stop refused: " + reply.reason;
    intake_.SetActive(false);
  } else if (msg.action == calibration_request_t::ACTION_COMMIT) {
    Commit();
  } else {
    last_error_ = "calibration_request_t: unknown action " + std::to_string(msg.action);
    Log(last_error_);
  }
}

RequestReply Agent::Start(const StartRequest& request) {
  RequestReply reply;
  if (solver_.joinable() && !solve_done_) {
    reply.reason = "the previous session's solve is still finishing";
  } else if (!diag_.Interlock()) {
    reply.reason = "the interlock is not asserted (agent.gpio.interlock)";
  } else {
    if (solver_.joinable()) solver_.join();  // an aborted session's finished solve
    reply = machine_.Start(request, MonotonicUs());
  }
  if (!reply.accepted) {
    last_error_ = "start refused (" + request.requester + "): " + reply.reason;
    Log(last_error_);
    return reply;
  }
  recorder_.Clear();
  has_outcome_ = result_published_ = false;
  last_error_.clear();
  intake_.SetActive(true);
  // Kept until the session ends: found at the next start-up, it tells of a run that died
  // mid-session. Not written (read-only store): the session runs, only that report is lost.
  // Written before the log line, so that whoever reads "started" finds the marker on disk.
  SessionMarker marker;
  marker.session = machine_.session();
  marker.trigger = request.requester;
  marker.started_unix_s = WallUs() / 1000000;
  std::string error;
  if (WriteSessionMarker(marker_path_, marker, &error))
    marker_session_ = marker.session;
  else
    Log("session marker not written: " + error);
  Log("session " + std::to_string(machine_.session()) + " started by '" + request.requester + "'");
  return reply;
}

void Agent::StartSolve() {
  CalibConfig calib = config_.calib;
  if (store_.current() != nullptr) calib.prior_T_camera_lidar = store_.current()->T_camera_lidar;
  solve_session_ = machine_.session();
  solve_started_us_ = MonotonicUs();
  solve_done_ = false;
  Log("solving session " + std::to_string(solve_session_) + ": " +
      std::to_string(recorder_.figures().frames_with_boards) + " frame pairs, " +
      std::to_string(recorder_.figures().boards) + " boards (" +
      CollectionEndName(machine_.collection_end()) + "), " +
      std::to_string(recorder_.session().num_frames) + " pairs kept" +
      (recorder_.thinning().stride() > 1
           ? " (1 run of " + std::to_string(SessionThinning::kRun) + " in " +
                 std::to_string(recorder_.thinning().stride()) + ")"
           : std::string()));
  solver_ = std::thread([this, calib] {
    NiceThisThread(kBackgroundNice);
    outcome_ = Calibrate(calib, recorder_.session(), projection_, config_.engine);
    solve_done_ = true;
    wake_.Signal();
  });
}

void Agent::FinishSolve() {
  solver_.join();
  has_outcome_ = true;
  const CalibrationOutcome& o = outcome_;
  if (!machine_.SolveFinished(solve_session_, o.verdict, o.reason, o.detail)) return;  // stopped
  Log(std::string("verdict ") + VerdictName(o.verdict) +
      (o.reason == Reason::kNone ? "" : " (" + std::string(NameOf(o.reason)) + ")") + ": " +
      o.detail + "; solved in " +
      std::to_string(static_cast<int>((MonotonicUs() - solve_started_us_) / 1000)) +
      " ms (grid search " + std::to_string(static_cast<int>(o.grid.search_ms)) + ", optimisation " +
      std::to_string(static_cast<int>(o.optimise_ms)) + ", quality " +
      std::to_string(static_cast<int>(o.quality_ms)) + ")");
  if (o.verdict == CalibrationOutcome::Verdict::kVerified && store_.current() != nullptr) {
    std::string error;
    const bool written = store_.MarkVerified(WallUs() / 1000000, &error);
    if (!written) {
      last_error_ = "store: " + error;
      Log(last_error_);
    }
    diag_.Report(uds::Dtc::kStoreWriteFailed, !written);
  }
  diag_.Report(uds::Dtc::kResultRejected, o.verdict == CalibrationOutcome::Verdict::kRejected);
  diag_.Report(uds::Dtc::kSessionInterrupted, false);  // a session ended with a result
  PublishResult();
  if (o.verdict == CalibrationOutcome::Verdict::kUpdated && config_.auto_commit &&
      !machine_.request().verify_only)
    Commit();
}

uds::BackendReply Agent::Commit() {
  const RequestReply reply = machine_.CommitRequested();
  if (!reply.accepted) {
    last_error_ = "commit refused: " + reply.reason;
    Log(last_error_);
    return uds::BackendReply::kSequenceError;
  }
  const CalibrationOutcome& o = outcome_;
  StoredCalibration c;
  c.created_unix_s = WallUs() / 1000000;
  c.T_camera_lidar = o.T_camera_lidar;
  c.lidar_serial = lidar_serial_.empty() ? "unknown" : lidar_serial_;
  c.camera_serial = camera_serial_.empty() ? "unknown" : camera_serial_;
  c.source = "agent:" + machine_.request().requester;
  c.verdict = VerdictName(o.verdict);
  c.reprojection_mean_px = o.quality.reprojection_mean_px;
  c.residual_rms_m = o.quality.residual_rms_m;
  c.rotation_sigma_deg = o.quality.rotation_sigma_deg;
  c.translation_sigma_m = o.quality.translation_sigma_m;
  c.frames_used = o.quality.frames_used;
  c.boards_used = o.quality.boards_used;
  std::string error;
  if (!store_.Commit(c, &error)) {
    machine_.CommitFailed(error);
    last_error_ = "store: " + error;
    Log(last_error_ + " (the previous calibration stays in use)");
    diag_.Report(uds::Dtc::kStoreWriteFailed, true);
    return uds::BackendReply::kFailure;
  }
  diag_.Report(uds::Dtc::kStoreWriteFailed, false);
  sensor_mismatch_ = false;
  diag_.Report(uds::Dtc::kCalibrationNotPerformed, false);
  diag_.Report(uds::Dtc::kRecalibrationRequired, false);
  diag_.Report(uds::Dtc::kStoreCorrupt, false);  // a valid current version was written
  Log("committed calibration version " + std::to_string(store_.current()->version));
  WriteExports();
  return uds::BackendReply::kAccepted;
}

void Agent::WriteExports() {
  const StoredCalibration* current = store_.current();
  if (current == nullptr) return;
  CalibrationExport e;
  e.T_camera_lidar = current->T_camera_lidar;
  e.camera_frame = config_.calib.camera_frame;
  e.lidar_frame = config_.calib.lidar_frame;
  e.software_version = config_.SoftwareVersion();
  e.calibrated_unix_s = current->created_unix_s;
  std::string error;
  if (!WriteCalibrationExports(config_.store.directory + "/export", e, &error))
    Log("exports of calibration version " + std::to_string(current->version) +
        " not written: " + error);
}

void Agent::Step(int64_t now_us) {
  if (diag_.TakeStartPress()) {
    StartRequest r;
    r.mode = SessionMode::kStatic;  // a factory line: the vehicle stands, the boards are placed
    r.requester = "start_button";
    Start(r);
  }
  if (diag_.has_interlock() &&
      (machine_.state() == SessionState::kCollecting ||
       machine_.state() == SessionState::kSolving) &&
      !diag_.Interlock()) {
    machine_.Stop(now_us, Reason::kInterlockReleased);
    Log("session " + std::to_string(machine_.session()) + " aborted: the interlock was released");
  }
  const bool collecting = machine_.state() == SessionState::kCollecting;
  if (collecting) {
    if (recorder_.DrainFrom(&intake_) > 0) machine_.FrameRecorded(recorder_.figures(), now_us);
    machine_.Tick(now_us);
    if (end_of_log_ && intake_.Idle()) machine_.EndOfData(now_us);
  } else {
    intake_.Drain(nullptr);  // pairs still in flight when the collection ended
  }
  {
    const IntakeCounters& c = intake_.counters();
    int64_t since_last = 0;
    if (malformed_log_.Due(c.bad_messages, now_us, &since_last))
      Log(MalformedMessagesLine(since_last, c.bad_messages, c.last_error));
  }
  if (machine_.state() != SessionState::kCollecting && intake_.active()) {
    intake_.SetActive(false);
    const IntakeCounters& c = intake_.counters();
    Log("collection ended (" + std::string(CollectionEndName(machine_.collection_end())) +
        "): " + std::to_string(c.camera_frames) + " camera and " + std::to_string(c.lidar_frames) +
        " LiDAR frames, " + std::to_string(c.pairs_formed) + " pairs formed, " +
        std::to_string(c.pairs_detected) + " detected, " + std::to_string(c.dropped_queue_full) +
        " dropped (queue full), " + std::to_string(c.camera_missed) + "/" +
        std::to_string(c.lidar_missed) + " camera/LiDAR missing from the streams, " +
        std::to_string(c.unpaired_camera) + "/" + std::to_string(c.unpaired_lidar) +
        " unpaired camera/LiDAR, " + std::to_string(c.out_of_order) +
        " out of order (camera/LiDAR duplicates " + std::to_string(c.camera_duplicates) + "/" +
        std::to_string(c.lidar_duplicates) + ", late " + std::to_string(c.camera_late) + "/" +
        std::to_string(c.lidar_late) + ", restarts " + std::to_string(c.camera_restarts) + "/" +
        std::to_string(c.lidar_restarts) + "), " + std::to_string(c.bad_messages) + " bad" +
        (c.last_error.empty() ? "" : " (last: " + c.last_error + ")") + ", " +
        std::to_string(c.over_capacity) + " over the session store's capacity; LiDAR detector: " +
        std::to_string(c.lidar_boards_dropped) + " boards and " +
        std::to_string(c.lidar_candidates_dropped) + " clusters beyond its capacity, " +
        std::to_string(c.lidar_points_overflow) + " points beyond max_points, " +
        std::to_string(c.lidar_boards_subsampled) + " boards subsampled to max_points_per_board" +
        (c.debug_write_failures > 0
             ? "; " + std::to_string(c.debug_write_failures) +
                   " --debug pair(s) not written (first: " + c.first_debug_error + ")"
             : std::string()));
  }
  if (machine_.NeedsSolve()) StartSolve();
  if (solver_.joinable() && solve_done_) FinishSolve();
  if (machine_.state() != SessionState::kCollecting && machine_.state() != SessionState::kSolving)
    EndSessionMarker();
  ReportDtcs(now_us);
  if (now_us - last_status_us_ >= static_cast<int64_t>(1e6 / config_.status_rate_hz)) {
    PublishStatus();
    last_status_us_ = now_us;
  }
  if (now_us - last_health_us_ >= static_cast<int64_t>(1e6 / config_.health_rate_hz)) {
    PublishHealth();
    last_health_us_ = now_us;
  }
}

void Agent::PublishStatus() {
  calibration_status_t s;
  s.utime = WallUs();
  s.state = StatusState(machine_.state());
  s.progress = static_cast<float>(machine_.progress());
  s.frames_used = recorder_.figures().frames_with_boards;
  s.boards_observed = recorder_.figures().boards;
  const IntakeCounters& c = intake_.counters();
  s.frames_dropped = static_cast<int32_t>(c.dropped_queue_full);
  if (machine_.reason() != Reason::kNone)
    s.last_error = std::string(NameOf(machine_.reason())) +
                   (machine_.detail().empty() ? "" : ": " + machine_.detail());
  else if (!last_error_.empty())
    s.last_error = last_error_;
  else
    s.last_error = c.last_error;
  s.guidance = machine_.guidance();
  Publish(channels::kStatus.name, s);
}

int8_t Agent::CalibrationState() const {
  if (store_.current() == nullptr) return health_t::CALIB_NOT_PERFORMED;
  if (sensor_mismatch_) return health_t::CALIB_RECALIBRATION_REQUIRED;
  return health_t::CALIB_VALID;
}

void Agent::PublishHealth() {
  health_t h;
  h.utime = WallUs();
  h.software_version = config_.SoftwareVersion();
  h.calibration_state = CalibrationState();
  const StoredCalibration* current = store_.current();
  h.calibration_age_s = current == nullptr ? 0
                                           : h.utime / 1000000 - std::max(current->created_unix_s,
                                                                          current->verified_unix_s);
  h.last_verdict =
      has_outcome_ ? ResultVerdict(outcome_.verdict) : calibration_result_t::VERDICT_NONE;
  h.last_reason = has_outcome_ ? NameOf(outcome_.reason) : "";
  h.last_delta_rotation_deg = has_outcome_ ? outcome_.delta_rotation_deg : 0.0;
  h.last_delta_translation_m = has_outcome_ ? outcome_.delta_translation_m : 0.0;
  h.last_reprojection_mean_px = has_outcome_ ? outcome_.quality.reprojection_mean_px : 0.0;
  // Frame rates over the last health period.
  const IntakeCounters& c = intake_.counters();
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
  h.camera_serial = camera_serial_;
  h.lidar_serial = lidar_serial_;
  // lcm-gen leaves scalars uninitialised: every field is set here.
  h.can_state = "off";
  h.can_link_losses = h.can_bus_off_events = 0;
  h.num_active_dtcs = 0;
  if (const CanLinkStatus* isotp = diag_.isotp_status()) {
    const CanLinkStatus* raw = diag_.raw_status();
    h.can_state = ToString(raw->state == CanLinkState::kBusOff ? raw->state : isotp->state);
    h.can_link_losses = static_cast<int32_t>(isotp->counters.link_losses);
    h.can_bus_off_events = static_cast<int32_t>(raw->counters.bus_off_events);
  }
  if (uds::UdsServer* server = diag_.server()) {
    for (size_t i = 0; i < uds::kDtcCount; ++i)
      if (server->dtcs().status(i) & uds::kTestFailed)
        h.active_dtcs.push_back(static_cast<int32_t>(uds::kDtcNumbers[i]));
    h.num_active_dtcs = static_cast<int16_t>(h.active_dtcs.size());
  }
  Publish(channels::kHealth.name, h);
}

void Agent::PublishResult() {
  const CalibrationOutcome& o = outcome_;
  calibration_result_t r;
  r.utime = WallUs();
  r.camera_id = config_.calib.camera_id;
  r.lidar_id = config_.calib.lidar_id;
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
  Publish(channels::kResult.name, r);
  result_published_ = true;
}

void Agent::NotifyStatus() {
  if (!notifier_.enabled()) return;
  const SessionState s = machine_.state();
  const int percent =
      s == SessionState::kCollecting ? static_cast<int>(machine_.progress() * 10.0) * 10 : 0;
  if (static_cast<int>(s) == notified_state_ && machine_.session() == notified_session_ &&
      percent == notified_percent_)
    return;
  notified_state_ = static_cast<int>(s);
  notified_session_ = machine_.session();
  notified_percent_ = percent;
  char text[SystemdNotifier::kMaxStatusChars + 1];
  const std::string reason(NameOf(machine_.reason()));
  if (s == SessionState::kIdle)
    std::snprintf(text, sizeof(text), "idle");
  else if (s == SessionState::kCollecting)
    std::snprintf(text, sizeof(text), "session %d: collecting %d%%", machine_.session(), percent);
  else if (s == SessionState::kDone)
    std::snprintf(text, sizeof(text), "session %d: done, %s%s%s%s", machine_.session(),
                  VerdictName(machine_.verdict()), reason.empty() ? "" : " (", reason.c_str(),
                  reason.empty() ? "" : ")");
  else
    std::snprintf(text, sizeof(text), "session %d: %s%s%s%s", machine_.session(),
                  SessionStateName(s), reason.empty() ? "" : " (", reason.c_str(),
                  reason.empty() ? "" : ")");
  notifier_.Status(text);
}

int Agent::Run() {
  const sigset_t signals = StopSignals();
  pthread_sigmask(SIG_BLOCK, &signals, nullptr);
  Fd signal_fd{signalfd(-1, &signals, SFD_CLOEXEC)};
  Fd timer_fd{timerfd_create(CLOCK_MONOTONIC, TFD_CLOEXEC)};
  if (signal_fd.fd < 0 || timer_fd.fd < 0) {
    Log(std::string("cannot create the loop's descriptors: ") + std::strerror(errno));
    return kAgentExitCannotRun;
  }
  // systemd watchdog (WatchdogSec=): WATCHDOG=1 every half interval (sd_watchdog_enabled(3)), at
  // the tick nearest to it, sent from this loop's timer only, so a stuck loop stops pinging and
  // systemd restarts it. The timer ticks at least 4 times per ping period.
  const int64_t ping_period_us = static_cast<int64_t>(notifier_.watchdog_interval_us() / 2);
  int64_t last_ping_us = 0;
  int64_t tick_ns = int64_t{kTickMs} * 1000000;
  if (ping_period_us > 0) tick_ns = std::clamp<int64_t>(ping_period_us * 250, 1000000, tick_ns);
  itimerspec period{};
  period.it_interval.tv_nsec = static_cast<long>(tick_ns);
  period.it_value = period.it_interval;
  timerfd_settime(timer_fd.fd, 0, &period, nullptr);
  const bool replay = bus_.url().rfind("file://", 0) == 0;
  notifier_.Ready();
  NotifyStatus();

  for (;;) {
    // A replay waits for the detectors instead of dropping frames: its bus is not polled while
    // the intake is full. A live stream is always read (the intake drops and counts instead).
    const bool read_bus = !end_of_log_ && !(replay && intake_.Full());
    pollfd fds[4 + Diagnostics::kMaxPollFds] = {{signal_fd.fd, POLLIN, 0},
                                                {timer_fd.fd, POLLIN, 0},
                                                {wake_.fd(), POLLIN, 0},
                                                {bus_.fileno(), POLLIN, 0}};
    // The bus last among the fixed ones: left out (not read) while a replay waits.
    int count = read_bus ? 4 : 3;
    const int first_diag = count;
    count += diag_.PollFds(fds + count);
    const int n = ::poll(fds, static_cast<nfds_t>(count), read_bus ? -1 : kTickMs);
    if (n < 0 && errno != EINTR) {
      Log(std::string("poll: ") + std::strerror(errno));
      return kAgentExitCannotRun;
    }
    if (fds[0].revents & POLLIN) {
      signalfd_siginfo info{};
      if (::read(signal_fd.fd, &info, sizeof(info)) > 0)
        Log(std::string("signal ") + strsignal(static_cast<int>(info.ssi_signo)) + ": stopping");
      notifier_.Stopping();
      machine_.Stop(MonotonicUs());
      EndSessionMarker();  // a clean stop: nothing to report at the next start
      return kAgentExitOk;
    }
    if (fds[1].revents & POLLIN) {
      uint64_t expirations = 0;
      if (::read(timer_fd.fd, &expirations, sizeof(expirations)) < 0) expirations = 0;
      const int64_t now_us = MonotonicUs();
      if (ping_period_us > 0 && now_us - last_ping_us >= ping_period_us - tick_ns / 2000) {
        notifier_.WatchdogPing();
        last_ping_us = now_us;
      }
    }
    if (fds[2].revents & POLLIN) wake_.Clear();
    if (!detectors_ready_ && !CheckDetectorStartup()) return kAgentExitCannotRun;
    bool diag_readable = false;
    for (int i = first_diag; i < count; ++i) diag_readable = diag_readable || fds[i].revents != 0;
    if (diag_readable) diag_.OnReadable(MonotonicUs());
    if (read_bus && (fds[3].revents & POLLIN)) {
      // A replay hands over one message at a time so that Full() is looked at between frames.
      if (bus_.Handle(0, replay ? 1 : 64) < 0) {
        if (!bus_.end_of_log()) {
          Log("LCM transport failed on " + bus_.url());
          return kAgentExitCannotRun;
        }
        end_of_log_ = true;
        Log("end of the replayed log");
      }
    }
    const int64_t step_us = MonotonicUs();
    Step(step_us);
    diag_.Tick(step_us, DiagnosticsNow());
    NotifyStatus();
    if (reset_requested_) {
      Log("ECU reset requested over UDS: restarting");
      notifier_.Stopping();
      machine_.Stop(step_us, Reason::kEcuReset);
      EndSessionMarker();
      return kAgentExitRestart;
    }
    if (options_.once) {
      const SessionState s = machine_.state();
      const bool session_over = machine_.session() > 0 && Terminal(s) && !solver_.joinable();
      if (session_over) {
        PublishStatus();
        PublishHealth();  // the final counts, for the fleet and for replays
        if (s != SessionState::kDone) return kAgentExitFailed;
        if (machine_.verdict() == CalibrationOutcome::Verdict::kRejected) return kAgentExitRejected;
        // Updated, but auto_commit could not write the store: a factory line must not take
        // it for stored.
        return machine_.commit_failed() ? kAgentExitNotStored : kAgentExitOk;
      }
      if (end_of_log_ && machine_.session() == 0) {
        Log("the log ended before any session was started");
        return kAgentExitFailed;
      }
    }
  }
}

}  // namespace calibd
