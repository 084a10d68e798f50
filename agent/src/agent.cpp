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

#include "calibd/channels.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"
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

Agent::Agent(const AgentConfig& config)
    : config_(config),
      machine_(SessionConfigFrom(config)),
      sensors_(config.calib.camera_id, config.calib.lidar_id) {}

Agent::~Agent() = default;

void Agent::Log(const std::string& line) const {
  if (!options_.quiet) std::cerr << "calibd-agent: " << line << std::endl;
}

void Agent::CheckInterruptedSession() {
  marker_.Open(config_.store.directory);
  std::string error;
  const std::string line = marker_.TakeInterrupted(&error);
  if (line.empty()) return;
  Log(line);
  // In CALIBD_STATUS until a session starts (Start clears it).
  last_error_ = "session_interrupted: " + line;
  diag_.Report(uds::Dtc::kSessionInterrupted, true);
  if (!error.empty()) Log("session marker: " + error);
}

bool Agent::CheckDetectorStartup() {
  const FrameIntake::Startup s = intake_.startup();
  if (s.failed) {
    Log(s.error + ": stopping");
    return false;
  }
  if (!s.ready) return true;
  detectors_ready_ = true;
  Log("LiDAR detector ready: " + std::to_string(s.references) + " reference descriptors " +
      (s.from_cache ? "from the cache" : "built") + " in " +
      std::to_string(static_cast<int64_t>(s.build_ms)) + " ms (at nice " +
      std::to_string(s.build_nice) + ")" + (s.cache_note.empty() ? "" : "; cache " + s.cache_note));
  return true;
}

void Agent::EndSessionMarker() {
  std::string error;
  if (!marker_.End(&error)) Log("session marker: " + error);
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
  const bool replay = bus_.is_replay();
  if (replay) {
    // A log is read at its own pace (and held back while the detectors catch up): the time
    // between its frames is not the sensors', so no sensor timeout (session_machine.hpp).
    SessionConfig session = SessionConfigFrom(config_);
    session.sensor_timeout_us = 0;
    machine_ = SessionMachine(session);
  }
  if (!reports_.Open(
          &bus_, options.publish_url, replay, [this](const std::string& line) { Log(line); },
          error))
    return false;
  if (!reports_.publishing())
    Log("replaying a log without --publish-url: status, health and results are not published");
  Log("ready on " + bus_.url() + " (camera '" + config_.calib.camera_id + "', LiDAR '" +
      config_.calib.lidar_id + "' " + config_.calib.lidar_model + ")");
  if (options.calibrate_now) {
    StartRequest r;
    r.requester = "--calibrate-now";
    Start(r);
  }
  return true;
}

void Agent::OnCamera(const camera_frame_t& msg) {
  const int64_t now_us = MonotonicUs();
  sensors_.FrameArrived(SensorStream::kCamera, now_us);
  if (detectors_ready_ && msg.camera_id == config_.calib.camera_id)
    machine_.FrameArrived(SensorStream::kCamera, now_us);
  intake_.OnCamera(msg);
}
void Agent::OnLidar(const lidar_frame_t& msg) {
  const int64_t now_us = MonotonicUs();
  sensors_.FrameArrived(SensorStream::kLidar, now_us);
  if (detectors_ready_ && msg.lidar_id == config_.calib.lidar_id)
    machine_.FrameArrived(SensorStream::kLidar, now_us);
  const int64_t pairs_formed = intake_.counters().pairs_formed;
  intake_.OnLidar(msg);
  if (intake_.counters().pairs_formed > pairs_formed) machine_.PairFormed(now_us);
}

void Agent::OnSensorInfo(const sensor_info_t& msg) {
  std::string line;
  if (!sensors_.OnSensorInfo(msg, store_.current(), &line)) return;
  diag_.Report(uds::Dtc::kRecalibrationRequired, true);
  Log(line);
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
  if (solve_.running()) {
    reply.reason = "the previous session's solve is still finishing";
  } else if (!diag_.Interlock()) {
    reply.reason = "the interlock is not asserted (agent.gpio.interlock)";
  } else {
    reply = machine_.Start(request, MonotonicUs());
  }
  if (!reply.accepted) {
    last_error_ = "start refused (" + request.requester + "): " + reply.reason;
    Log(last_error_);
    return reply;
  }
  recorder_.Clear();
  solve_.Clear();  // the last session's outcome, or an aborted session's finished solve
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
  if (!marker_.Begin(marker, &error)) Log("session marker not written: " + error);
  Log("session " + std::to_string(machine_.session()) + " started by '" + request.requester + "'");
  return reply;
}

void Agent::StartSolve() {
  CalibConfig calib = config_.calib;
  if (store_.current() != nullptr) calib.prior_T_camera_lidar = store_.current()->T_camera_lidar;
  Log("solving session " + std::to_string(machine_.session()) + ": " +
      std::to_string(recorder_.figures().frames_with_boards) + " frame pairs, " +
      std::to_string(recorder_.figures().boards) + " boards (" +
      CollectionEndName(machine_.collection_end()) + "), " +
      std::to_string(recorder_.session().num_frames) + " pairs kept" +
      (recorder_.thinning().stride() > 1
           ? " (1 run of " + std::to_string(SessionThinning::kRun) + " in " +
                 std::to_string(recorder_.thinning().stride()) + ")"
           : std::string()));
  solve_.Start(machine_.session(), calib, recorder_.session(), projection_, config_.engine, &wake_,
               MonotonicUs());
}

void Agent::FinishSolve() {
  solve_.Collect();
  const CalibrationOutcome& o = *solve_.outcome();
  if (!machine_.SolveFinished(solve_.session(), o.verdict, o.reason, o.detail)) return;  // stopped
  Log(std::string("verdict ") + VerdictName(o.verdict) +
      (o.reason == Reason::kNone ? "" : " (" + std::string(NameOf(o.reason)) + ")") + ": " +
      o.detail + "; solved in " +
      std::to_string(static_cast<int>((MonotonicUs() - solve_.started_us()) / 1000)) +
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
  reports_.PublishResult(o, config_.calib);
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
  const CalibrationOutcome& o = *solve_.outcome();
  StoredCalibration c;
  c.created_unix_s = WallUs() / 1000000;
  c.T_camera_lidar = o.T_camera_lidar;
  const std::string& lidar_serial = sensors_.serial(SensorStream::kLidar);
  const std::string& camera_serial = sensors_.serial(SensorStream::kCamera);
  c.lidar_serial = lidar_serial.empty() ? "unknown" : lidar_serial;
  c.camera_serial = camera_serial.empty() ? "unknown" : camera_serial;
  c.source = "agent:" + machine_.request().requester;
  c.verdict = VerdictName(o.verdict);
  c.reprojection_mean_px = o.quality.reprojection_mean_px;
  c.residual_rms_m = o.quality.residual_rms_m;
  c.rotation_sigma_deg = o.quality.rotation_sigma_deg;
  c.translation_sigma_m = o.quality.translation_sigma_m;
  // No bound (the session could not bound its error): stored as unknown.
  if (o.quality.has_error_bound()) {
    c.rotation_bound_deg = o.quality.rotation_bound_deg;
    c.translation_bound_m = o.quality.translation_bound_m;
  }
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
  CalibrationStored();
  diag_.Report(uds::Dtc::kRecalibrationRequired, false);
  diag_.Report(uds::Dtc::kStoreCorrupt, false);  // a valid current version was written
  Log("committed calibration version " + std::to_string(store_.current()->version));
  WriteExports();
  return uds::BackendReply::kAccepted;
}

void Agent::CalibrationStored() {
  diag_.Report(uds::Dtc::kStoreWriteFailed, false);
  sensors_.ClearMismatch();
  diag_.Report(uds::Dtc::kCalibrationNotPerformed, false);
}

void Agent::WriteExports() {
  const StoredCalibration* current = store_.current();
  if (current == nullptr) return;
  CalibrationExport e;
  e.T_camera_lidar = current->T_camera_lidar;
  e.camera_frame = config_.calib.camera_frame;
  e.lidar_frame = config_.calib.lidar_frame;
  e.software_version = software_version_;
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
    LogCollectionEnd();
  }
  if (machine_.NeedsSolve()) StartSolve();
  if (solve_.finished()) FinishSolve();
  if (machine_.state() != SessionState::kCollecting && machine_.state() != SessionState::kSolving)
    EndSessionMarker();
  ReportDtcs(now_us);
  if (LcmReports::Due(config_.status_rate_hz, now_us, &last_status_us_)) PublishStatus();
  if (LcmReports::Due(config_.health_rate_hz, now_us, &last_health_us_)) PublishHealth();
}

void Agent::LogCollectionEnd() {
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

void Agent::PublishStatus() {
  reports_.PublishStatus(machine_, recorder_.figures(), intake_.counters(), last_error_);
}

void Agent::PublishHealth() {
  HealthFacts facts;
  facts.software_version = software_version_;
  switch (State()) {
    case uds::CalibrationState::kValid:
      facts.calibration_state = health_t::CALIB_VALID;
      break;
    case uds::CalibrationState::kNotPerformed:
      facts.calibration_state = health_t::CALIB_NOT_PERFORMED;
      break;
    case uds::CalibrationState::kRecalibrationRequired:
      facts.calibration_state = health_t::CALIB_RECALIBRATION_REQUIRED;
      break;
  }
  facts.current = store_.current();
  facts.outcome = solve_.outcome();
  facts.camera_serial = sensors_.serial(SensorStream::kCamera);
  facts.lidar_serial = sensors_.serial(SensorStream::kLidar);
  reports_.PublishHealth(facts, intake_.counters(), diag_);
}

void Agent::NotifyStatus() {
  if (!notifier_.enabled()) return;
  if (const char* text = service_status_.Changed(machine_)) notifier_.Status(text);
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
  const bool replay = bus_.is_replay();
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
      const int code = OnceExitCode();
      if (code >= 0) return code;
    }
  }
}

int Agent::OnceExitCode() {
  const SessionState s = machine_.state();
  if (machine_.session() > 0 && Terminal(s) && !solve_.pending()) {
    // The final counts, for the fleet and for replays.
    PublishStatus();
    PublishHealth();
    if (s != SessionState::kDone) return kAgentExitFailed;
    if (machine_.verdict() == CalibrationOutcome::Verdict::kRejected) return kAgentExitRejected;
    // Updated, but auto_commit could not write the store: a factory line must not take it for
    // stored.
    return machine_.commit_failed() ? kAgentExitNotStored : kAgentExitOk;
  }
  if (end_of_log_ && machine_.session() == 0) {
    Log("the log ended before any session was started");
    return kAgentExitFailed;
  }
  return -1;
}

}  // namespace calibd
