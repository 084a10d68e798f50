#pragma once
/// \file
/// One calibration session as a state machine. Pure logic: no I/O, no threads, no clock.
/// The caller (the agent's poll loop) feeds it requests, recorded frames, solver results and a
/// monotonic time in microseconds, and acts on what it reports:
///
///   kIdle --Start--> kCollecting --target frames | coverage gates | time limit--> kSolving
///   kCollecting --time limit with too few frames or boards--> kFailed
///   kCollecting --a sensor silent, or no pair, for sensor_timeout_us--> kSolving with enough
///                 frames and boards, else kFailed (camera_timeout, lidar_timeout, no_pairs)
///   kSolving --SolveFinished--> kDone (verdict verified / updated / rejected)
///   kSolving --SolveFailed--> kFailed
///   kCollecting, kSolving --Stop--> kAborted
///   kDone, kFailed, kAborted --Start--> kCollecting (a fresh session)
///
/// Triggers (an LCM calibration_request_t, `--calibrate-now`, later a CAN diagnostic routine) all
/// go through Start. While collecting, FrameRecorded and Tick allocate nothing.

#include <cstdint>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/capture_guidance.hpp"
#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd {

enum class SessionState { kIdle, kCollecting, kSolving, kDone, kFailed, kAborted };
/// "idle", "collecting", "solving", "done", "failed", "aborted".
const char* SessionStateName(SessionState state);

/// How the boards pass the sensors (calibration_request_t MODE_*): the vehicle drives past them,
/// or it is parked and the boards are moved. Changes only the operator guidance.
enum class SessionMode { kMoving, kStatic };

/// The two streams a session needs (FrameArrived).
enum class SensorStream { kCamera, kLidar };

/// What ended the collection of the current session.
enum class CollectionEnd {
  kNone,
  kTargetFrames,
  kCoverage,
  kTimeLimit,
  kEndOfData,
  kStopped,
  kSensorTimeout,  ///< a sensor fell silent or no pair came (SessionConfig::sensor_timeout_us)
};
/// "none", "target_frames", "coverage", "time_limit", "end_of_data", "stopped", "sensor_timeout".
const char* CollectionEndName(CollectionEnd end);

/// Upper bound of a request's collection time limit, us (the config's own limit is validated to
/// the same bound).
inline constexpr int64_t kMaxSessionDurationUs = 3600LL * 1000 * 1000;

struct StartRequest {
  SessionMode mode = SessionMode::kMoving;
  int64_t max_duration_us = 0;  ///< collection time limit; 0: the config's
  /// calibration_request_t ACTION_VERIFY: the session runs as usual but an `updated` result may
  /// not be committed (the stored calibration is only checked).
  bool verify_only = false;
  std::string requester;  ///< free text for logs ("tester", "eol-station-3", "--calibrate-now")
};

/// Answer to a request that may be refused.
struct RequestReply {
  bool accepted = false;
  std::string reason;  ///< why it was refused, for the requester and the log; empty if accepted
};

/// Cumulative figures of what the session has recorded so far (the caller's session buffer).
struct CollectionFigures {
  int frames_with_boards = 0;  ///< frame pairs with at least one board seen by both sensors
  int boards = 0;              ///< board observations seen by both sensors
  uint32_t distance_bins = 0;  ///< bit b set: a board seen in DistanceBin() b
  uint32_t image_cells = 0;    ///< bit c set: a board centre in ImageCell() c
};

/// Distance bin (0 .. kDistanceBins - 1) of a camera-to-board distance in m (kDistanceBinEdgesM);
/// -1 for a negative or NaN distance.
int DistanceBin(double distance_m);

/// The part of the agent config the machine uses.
struct SessionConfig {
  CoverageGates gates;
  int64_t max_duration_us = 120LL * 1000 * 1000;  ///< collection time limit unless requested
  bool stop_on_coverage = true;  ///< end collection once the gates and min_frames are met
  /// A sensor that sent a frame in this session and then none for longer than this (arrival
  /// time, us) ends the collection (CollectionEnd::kSensorTimeout): solving with min_frames and
  /// min_boards, else failing with "camera_timeout" / "lidar_timeout"; so does no frame pair
  /// recorded for this long while both send ("no_pairs": their capture times do not pair, e.g.
  /// one clock jumped). 2 s, as core/stream_gaps.hpp's restart: a shorter pause is lost frames
  /// (counted), a longer one a stopped sensor. 0: off (the agent replaying a log, whose reading
  /// pace is not the sensors').
  int64_t sensor_timeout_us = 2000000;
};

/// From a validated AgentConfig (min_boards is the engine's verdict.min_boards).
SessionConfig SessionConfigFrom(const AgentConfig& config);

class SessionMachine {
 public:
  /// `config` must come from a validated AgentConfig (SessionConfigFrom).
  explicit SessionMachine(const SessionConfig& config);

  // --- inputs ---

  /// Begins a fresh session (from kIdle, kDone, kFailed or kAborted). Refused while a session is
  /// collecting or solving ("recalibration in progress ..."), or for a time limit outside
  /// [0, kMaxSessionDurationUs].
  RequestReply Start(const StartRequest& request, int64_t now_us);
  /// Aborts a collecting or solving session (a running solve's result will be ignored). Refused
  /// when no session is in progress.
  /// `reason` is the aborted session's: kStopped for a stop request; others name what ended it
  /// (kSessionEnded when the diagnostic session ended, kInterlockReleased, kEcuReset).
  RequestReply Stop(int64_t now_us, Reason reason = Reason::kStopped);
  /// A frame pair entered the session buffer; `figures` are the session's totals so far. May end
  /// the collection (target frames, coverage gates, time limit). False (ignored) when not
  /// collecting: frames keep arriving after collection ends.
  bool FrameRecorded(const CollectionFigures& figures, int64_t now_us);
  /// A message of the configured sensor arrived (well-formed or not: this watches for silence).
  /// Ignored unless collecting.
  void FrameArrived(SensorStream sensor, int64_t now_us);
  /// A camera frame and a sweep paired by their capture times (before detection, which may lag
  /// behind on a loaded CPU): the streams are not "sending, but unpaired". Ignored unless
  /// collecting.
  void PairFormed(int64_t now_us);
  /// Advances the time: may end the collection at its time limit or on a sensor timeout.
  void Tick(int64_t now_us);
  /// The input ended (a replayed log was read to its end): the collection ends as at its time
  /// limit, solving when there are enough frames and boards, else failing. Ignored unless
  /// collecting.
  void EndOfData(int64_t now_us);
  /// The solve of session `session` (session() when it began) ended with a verdict: kDone.
  /// `reason` is the engine's (kNone unless rejected), `detail` its explanation.
  /// False (ignored) when that session is no longer solving, e.g. stopped meanwhile.
  bool SolveFinished(int session, CalibrationOutcome::Verdict verdict, Reason reason,
                     const std::string& detail);
  /// The solve of session `session` could not run to a verdict: kFailed with `reason`.
  bool SolveFailed(int session, Reason reason, const std::string& detail);
  /// Accepted only in kDone with an `updated` verdict not yet committed (and not verify-only):
  /// the caller then writes the result to the store. The session counts as committed from here.
  RequestReply CommitRequested();
  /// The caller's store write failed after CommitRequested: the result may be committed again.
  void CommitFailed(const std::string& detail);

  /// Edge: true exactly once after collection ended in kSolving. The caller then runs the
  /// engine on the session buffer and reports SolveFinished or SolveFailed with session().
  bool NeedsSolve();

  // --- outputs ---

  SessionState state() const { return state_; }
  /// Number of the current session: 0 before the first Start, then 1, 2, ...
  int session() const { return session_; }
  /// 0..1, never decreasing within a session: collection covers [0, 0.9] (the larger of frames
  /// vs target and time vs limit), solving 0.9, kDone 1. kFailed and kAborted keep the value.
  double progress() const { return progress_; }
  /// The reason of the last failure, abort or rejection (kTooFewFrames, kStopped, the engine's
  /// reason...); kNone otherwise.
  Reason reason() const { return reason_; }
  /// Human-readable explanation of reason() with its figures.
  const std::string& detail() const { return detail_; }
  /// What the operator should do next: while collecting, the distance bins and image regions
  /// still lacking boards; after an uncommitted `updated` result, to commit it. Else empty.
  const std::string& guidance() const { return guidance_; }
  /// The session's coverage against the gates (what guidance() words while collecting).
  CaptureCoverage Coverage() const;
  /// The solve's verdict (meaningful in kDone).
  CalibrationOutcome::Verdict verdict() const { return verdict_; }
  bool committed() const { return committed_; }
  /// The last commit (CommitFailed) could not be written and none went through since: reason()
  /// is then kCommitFailed, the news until a commit succeeds.
  bool commit_failed() const { return reason_ == Reason::kCommitFailed; }
  CollectionEnd collection_end() const { return collection_end_; }
  const CollectionFigures& figures() const { return figures_; }
  const StartRequest& request() const { return request_; }
  int64_t started_us() const { return started_us_; }
  /// Collection time limit of the current session, us.
  int64_t limit_us() const { return limit_us_; }

 private:
  /// Ends the collection when one of its conditions holds (target, coverage, time).
  void CheckCollectionEnd(int64_t now_us);
  /// Ends the collection before its target (time limit or end of data): solving with enough
  /// frames and boards, else kFailed naming what was short (or the sensor that sent nothing).
  void FinishCollection(CollectionEnd end);
  /// kFailed when a sensor fell silent or no pair came for sensor_timeout_us; true if so.
  bool CheckSensorTimeout(int64_t now_us);
  void EnterSolving(CollectionEnd end);
  void EnterFailed(Reason reason);
  void UpdateProgress(int64_t now_us);
  void UpdateGuidance();
  bool CoverageMet() const;

  SessionConfig config_;
  SessionState state_ = SessionState::kIdle;
  int session_ = 0;
  StartRequest request_;
  int64_t started_us_ = 0, limit_us_ = 0;
  CollectionFigures figures_;
  CollectionEnd collection_end_ = CollectionEnd::kNone;
  /// Arrival of the latest camera frame, LiDAR frame and recorded pair in this session (0: none).
  int64_t last_camera_us_ = 0, last_lidar_us_ = 0, last_pair_us_ = 0;
  /// When both sensors had sent in this session (0: not yet): the no-pair timeout counts from
  /// there, not from the session's start, which may be long before the sensors start.
  int64_t both_sending_us_ = 0;
  bool solve_pending_ = false;
  CalibrationOutcome::Verdict verdict_ = CalibrationOutcome::Verdict::kRejected;
  bool committed_ = false;
  double progress_ = 0.0;
  // Reserved once: rewritten while collecting without allocating.
  Reason reason_ = Reason::kNone;
  std::string detail_, guidance_;
};

}  // namespace calibd
