#pragma once
/// \file
/// calibd-agent: the composition root. One poll loop over the LCM file descriptor, a timerfd and
/// a signalfd runs everything: frames from LCM go to the intake (detection on its two worker
/// threads), drained observations drive the session machine, the solve runs on its own thread
/// (solve_runner.hpp, so status keeps flowing), and the verdict is applied to the calibration
/// store. Its collaborators: the sensors' liveness and serials (sensor_watch.hpp), the LCM
/// reports (lcm_reports.hpp: status at status_rate_hz, health at health_rate_hz, a result when a
/// session ends), CAN and GPIO (diagnostics.hpp, with this class as the UDS server's backend),
/// the session marker (session_marker.hpp) and systemd's STATUS= (service_status.hpp).
///
/// Calibration state (health_t.calibration_state): `valid` when the store holds a calibration
/// for the sensors in use, `not_performed` when it holds none, `recalibration_required` when a
/// sensor_info message reports a serial number other than the stored calibration's (a replaced
/// sensor) until a calibration for the new sensors is committed.

#include <cstdint>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/diagnostics.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/lcm_reports.hpp"
#include "calibd/agent/rate_limited_log.hpp"
#include "calibd/agent/sensor_watch.hpp"
#include "calibd/agent/service_status.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/agent/session_marker.hpp"
#include "calibd/agent/session_recorder.hpp"
#include "calibd/agent/solve_runner.hpp"
#include "calibd/calibration_request_t.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/lcm_bus.hpp"
#include "calibd/drivers/systemd_notify.hpp"
#include "calibd/sensor_info_t.hpp"

namespace calibd {

struct AgentOptions {
  std::string lcm_url;  ///< overrides agent.lcm_url when not empty
  /// Where status, health and results go when not on the input bus: required to see them when
  /// replaying a file:// log (a log read is not writable), e.g. a udpm URL or
  /// file:///path/out.lcmlog?mode=w. Empty: the input bus (nowhere for a replay).
  std::string publish_url;
  bool calibrate_now = false;  ///< start a session at once (as a start request would)
  /// Exit once the first session has ended (and, with auto_commit, been committed), and at the
  /// end of a file:// log: for replays and scripts. Exit code: see Agent::Run.
  bool once = false;
  bool quiet = false;  ///< no log lines on stderr
  /// Replays only: what the detectors made of each pair goes there (IntakeConfig::debug_dir);
  /// created when missing.
  std::string debug_dir;
};

/// calibd-agent's exit codes (the integration guide's table, "Exit codes of calibd-agent").
inline constexpr int kAgentExitOk = 0;         ///< stopped by a signal; --once: verified/updated
inline constexpr int kAgentExitCannotRun = 1;  ///< could not start, or the loop failed
inline constexpr int kAgentExitBadConfig = 2;  ///< bad option or config (the message names it)
inline constexpr int kAgentExitRejected = 3;   ///< --once: the verdict was rejected
inline constexpr int kAgentExitFailed = 4;     ///< --once: failed, aborted, or no session
inline constexpr int kAgentExitNotStored = 5;  ///< --once: updated, but auto_commit failed
/// Run()'s exit code when a diagnostic tester asked for an ECU reset (UDS 0x11 01): the caller
/// (main) re-executes the program, which restarts the agent in place.
inline constexpr int kAgentExitRestart = 10;

class Agent : private uds::UdsBackend {
 public:
  explicit Agent(const AgentConfig& config);
  ~Agent() override;
  Agent(const Agent&) = delete;
  Agent& operator=(const Agent&) = delete;

  /// Opens the store, builds the detectors and the session buffer, opens LCM and subscribes.
  /// False with `error` saying what could not be set up.
  bool Init(const AgentOptions& options, std::string* error);

  /// The poll loop, until SIGTERM/SIGINT (exit code 0) or, with `once`, until the first session
  /// ended: 0 for verified or updated, 3 for rejected, 4 for failed or aborted. 1 when the loop
  /// itself fails (LCM transport error).
  int Run();

 private:
  void OnCamera(const camera_frame_t& msg);
  void OnLidar(const lidar_frame_t& msg);
  void OnSensorInfo(const sensor_info_t& msg);
  void OnRequest(const calibration_request_t& msg);
  /// Starts a session unless refused (a session running, the interlock released); the reason
  /// is logged and kept in last_error_.
  RequestReply Start(const StartRequest& request);
  /// Commits the last `updated` result. kAccepted, kSequenceError (nothing to commit) or
  /// kFailure (the store write failed: the previous calibration stays in use).
  uds::BackendReply Commit() override;
  /// DTC test results from the agent's state (agent_uds.cpp): calibration performed, sensor
  /// replaced, sensor data timeouts (while collecting), store problems. `now_us` monotonic.
  void ReportDtcs(int64_t now_us);
  DiagnosticsView DiagnosticsNow() const;

  // uds::UdsBackend (agent_uds.cpp): the diagnostic server's view of the agent.
  uds::RoutineConditions Conditions() const override;
  uds::BackendReply StartCalibration(const uds::CalibrateOptions& options) override;
  uds::BackendReply StopCalibration() override;
  void AbortCalibration() override;
  uds::RoutineSnapshot CalibrationStatus() const override;
  uds::BackendReply RestoreReference() override;
  uds::BackendReply StoreReference() override;
  std::string_view Vin() const override { return vin_; }
  bool WriteVin(std::string_view vin) override;
  std::string_view SoftwareVersion() const override { return software_version_; }
  int64_t CalibrationUnixS() const override;
  uds::ExtrinsicFigures CurrentExtrinsic() const override;
  uds::ExtrinsicFigures ReferenceExtrinsic() const override;
  uds::QualityFigures Quality() const override;
  std::string_view LidarSerial() const override;
  std::string_view CameraSerial() const override;
  uds::CalibrationState State() const override;
  CaptureCoverage Coverage() const override { return machine_.Coverage(); }
  void ResetRequested() override { reset_requested_ = true; }

  /// Drains the intake, advances the machine, starts or collects the solve; `now_us` monotonic.
  void Step(int64_t now_us);
  void StartSolve();
  void FinishSolve();
  void PublishStatus();
  void PublishHealth();
  /// STATUS= for systemd when it changed (service_status.hpp).
  void NotifyStatus();
  /// Logs the collection's counts once it ended.
  void LogCollectionEnd();
  /// Writes the store's current calibration in other stacks' formats into
  /// `<agent.store.directory>/export/` (drivers/calibration_export.hpp), each file atomically,
  /// after every change of the current calibration. A failure is logged, never fatal: the store
  /// holds the calibration, the exports are copies.
  void WriteExports();
  /// A calibration for the sensors in use was stored: the DTCs it clears.
  void CalibrationStored();
  void Log(const std::string& line) const;
  /// At start-up: a session marker left by the previous run means it stopped during a session;
  /// logs it, reports DTC 5A0300 and removes the marker.
  void CheckInterruptedSession();
  /// Removes the session marker once the session has ended (any outcome) or on a clean stop.
  void EndSessionMarker();
  /// Until the intake's LiDAR detector is ready: logs it once ready; false (the agent stops, as
  /// for a config it cannot run) when it could not be built.
  bool CheckDetectorStartup();
  /// --once: the exit code once the first session is over (publishing the final status and
  /// health first), else -1.
  int OnceExitCode();

  AgentConfig config_;
  AgentOptions options_;

  LcmBus bus_;
  LcmReports reports_;
  /// Signalled by the solve thread and the intake's workers when they have something for the
  /// poll loop (a finished solve, a pair to drain): it reacts at once, not at its next tick.
  /// Declared before intake_ and solve_ so that it outlives their threads.
  WakeEvent wake_;
  FrameIntake intake_;
  SessionMachine machine_;
  CalibrationStore store_;
  RangeImage projection_;
  SessionRecorder recorder_;  ///< the session store (sized once from the config) and figures
  /// Reads recorder_'s session, projection_ and config_.engine while it solves: none of them
  /// changes then (a new session cannot start before the solve finished).
  SolveRunner solve_;
  SensorWatch sensors_;

  std::string last_error_;
  int64_t last_status_us_ = 0, last_health_us_ = 0;
  bool end_of_log_ = false;
  /// The intake's LiDAR detector is built (it builds on its worker after Init): until then the
  /// sensors' frames are not taken as arrived by the session (the intake ignores them).
  bool detectors_ready_ = false;
  /// Malformed messages (intake bad_messages): the first logged at once, then one line per 10 s
  /// with their count at most.
  RateLimitedLog malformed_log_;

  /// CAN (UDS, status frame) and GPIO; each part optional (agent.can, agent.gpio).
  Diagnostics diag_;
  std::string vin_;               ///< DID 0xF190, kept in <agent.uds.state_dir>/vin
  std::string software_version_;  ///< DID 0xF195
  bool reset_requested_ = false;  ///< UDS 0x11: Run returns kAgentExitRestart
  SessionMarkerFile marker_;      ///< `<agent.store.directory>/session_in_progress`

  /// Type=notify unit: READY=1, STATUS=, WATCHDOG=1 from the loop's timer, STOPPING=1.
  SystemdNotifier notifier_;
  ServiceStatus service_status_;
};

}  // namespace calibd
