#include "calibd/agent/session_machine.hpp"

#include <algorithm>
#include <cmath>

#include "append_int.hpp"

namespace calibd {

namespace {

constexpr double kCollectingShare = 0.9;  // of the progress; the solve takes the rest
constexpr size_t kTextCapacity = 512;     // longest guidance is about 200 characters

}  // namespace

const char* SessionStateName(SessionState state) {
  switch (state) {
    case SessionState::kIdle:
      return "idle";
    case SessionState::kCollecting:
      return "collecting";
    case SessionState::kSolving:
      return "solving";
    case SessionState::kDone:
      return "done";
    case SessionState::kFailed:
      return "failed";
    case SessionState::kAborted:
      return "aborted";
  }
  return "unknown";
}

const char* CollectionEndName(CollectionEnd end) {
  switch (end) {
    case CollectionEnd::kNone:
      return "none";
    case CollectionEnd::kTargetFrames:
      return "target_frames";
    case CollectionEnd::kCoverage:
      return "coverage";
    case CollectionEnd::kTimeLimit:
      return "time_limit";
    case CollectionEnd::kEndOfData:
      return "end_of_data";
    case CollectionEnd::kStopped:
      return "stopped";
    case CollectionEnd::kSensorTimeout:
      return "sensor_timeout";
  }
  return "unknown";
}

int DistanceBin(double distance_m) {
  if (!(distance_m >= 0.0)) return -1;  // negative or NaN
  for (size_t b = 0; b < kDistanceBinEdgesM.size(); ++b) {
    if (distance_m < kDistanceBinEdgesM[b]) return static_cast<int>(b);
  }
  return kDistanceBins - 1;
}

SessionConfig SessionConfigFrom(const AgentConfig& config) {
  SessionConfig s;
  s.gates.target_frames = config.target_frames;
  s.gates.min_frames = config.min_frames;
  s.gates.min_boards = config.engine.verdict.min_boards;
  s.max_duration_us = static_cast<int64_t>(std::llround(config.max_duration_s * 1e6));
  s.gates.min_distance_bins = config.min_distance_bins;
  s.gates.min_image_cells = config.min_image_cells;
  s.stop_on_coverage = config.stop_on_coverage;
  return s;
}

SessionMachine::SessionMachine(const SessionConfig& config) : config_(config) {
  detail_.reserve(kTextCapacity);
  guidance_.reserve(kTextCapacity);
}

RequestReply SessionMachine::Start(const StartRequest& request, int64_t now_us) {
  RequestReply reply;
  if (state_ == SessionState::kCollecting || state_ == SessionState::kSolving) {
    reply.reason = "recalibration in progress (session " + std::to_string(session_) + " " +
                   SessionStateName(state_) + ", requested by '" + request_.requester + "')";
    return reply;
  }
  if (request.max_duration_us < 0 || request.max_duration_us > kMaxSessionDurationUs) {
    reply.reason = "time limit must be in [0, " + std::to_string(kMaxSessionDurationUs / 1000) +
                   "] ms, 0 for the configured one (got " +
                   std::to_string(request.max_duration_us / 1000) + " ms)";
    return reply;
  }
  ++session_;
  request_ = request;
  started_us_ = now_us;
  limit_us_ = request.max_duration_us > 0 ? request.max_duration_us : config_.max_duration_us;
  figures_ = CollectionFigures{};
  collection_end_ = CollectionEnd::kNone;
  last_camera_us_ = last_lidar_us_ = last_pair_us_ = both_sending_us_ = 0;
  solve_pending_ = false;
  verdict_ = CalibrationOutcome::Verdict::kRejected;
  committed_ = false;
  progress_ = 0.0;
  reason_ = Reason::kNone;
  detail_.clear();
  state_ = SessionState::kCollecting;
  UpdateGuidance();
  reply.accepted = true;
  return reply;
}

RequestReply SessionMachine::Stop(int64_t now_us, Reason reason) {
  RequestReply reply;
  if (state_ != SessionState::kCollecting && state_ != SessionState::kSolving) {
    reply.reason = std::string("no session in progress (") + SessionStateName(state_) + ")";
    return reply;
  }
  if (state_ == SessionState::kCollecting) {
    UpdateProgress(now_us);
    collection_end_ = CollectionEnd::kStopped;
  }
  reason_ = reason;
  if (reason_ == Reason::kStopped) {
    detail_ = "stopped by request while ";
  } else {
    detail_ = NameOf(reason_);
    detail_ += " while ";
  }
  detail_ += SessionStateName(state_);
  detail_ += " (";
  AppendInt(&detail_, figures_.frames_with_boards);
  detail_ += " frame pairs with boards)";
  solve_pending_ = false;  // a solve already running reports to a session that is gone
  state_ = SessionState::kAborted;
  UpdateGuidance();
  reply.accepted = true;
  return reply;
}

bool SessionMachine::FrameRecorded(const CollectionFigures& figures, int64_t now_us) {
  if (state_ != SessionState::kCollecting) return false;
  figures_ = figures;
  last_pair_us_ = now_us;
  CheckCollectionEnd(now_us);
  if (state_ == SessionState::kCollecting) UpdateGuidance();
  return true;
}

void SessionMachine::FrameArrived(SensorStream sensor, int64_t now_us) {
  if (state_ != SessionState::kCollecting) return;
  (sensor == SensorStream::kCamera ? last_camera_us_ : last_lidar_us_) = now_us;
  if (both_sending_us_ == 0 && last_camera_us_ > 0 && last_lidar_us_ > 0) both_sending_us_ = now_us;
}

void SessionMachine::PairFormed(int64_t now_us) {
  if (state_ == SessionState::kCollecting) last_pair_us_ = now_us;
}

void SessionMachine::Tick(int64_t now_us) {
  if (state_ == SessionState::kCollecting) CheckCollectionEnd(now_us);
}

bool SessionMachine::CheckSensorTimeout(int64_t now_us) {
  const int64_t timeout = config_.sensor_timeout_us;
  if (timeout <= 0) return false;
  // Only a sensor that sent in this session can stop: one that never did is named when the
  // collection ends short (FinishCollection), since the agent may start before the sensors.
  const bool camera_silent = last_camera_us_ > 0 && now_us - last_camera_us_ > timeout;
  const bool lidar_silent = last_lidar_us_ > 0 && now_us - last_lidar_us_ > timeout;
  const bool unpaired = last_camera_us_ > 0 && last_lidar_us_ > 0 && !camera_silent &&
                        !lidar_silent &&
                        now_us - std::max(last_pair_us_, both_sending_us_) > timeout;
  if (!camera_silent && !lidar_silent && !unpaired) return false;
  if (figures_.frames_with_boards >= config_.gates.min_frames &&
      figures_.boards >= config_.gates.min_boards) {
    EnterSolving(CollectionEnd::kSensorTimeout);  // enough already: solve what was collected
    return true;
  }
  collection_end_ = CollectionEnd::kSensorTimeout;
  if (unpaired) {
    EnterFailed(Reason::kNoPairs);
    detail_ = "camera and LiDAR: both sending, but no frame pair for more than ";
  } else {
    // Both silent: the one silent longer is named.
    const bool lidar = lidar_silent && (!camera_silent || last_lidar_us_ <= last_camera_us_);
    EnterFailed(lidar ? Reason::kLidarTimeout : Reason::kCameraTimeout);
    detail_ = lidar ? "LiDAR: no frame for more than " : "camera: no frame for more than ";
  }
  AppendInt(&detail_, timeout / 1000);
  detail_ += unpaired ? " ms while collecting (their capture times do not pair, or every pair "
                        "was malformed), "
                      : " ms while collecting, ";
  AppendInt(&detail_, figures_.frames_with_boards);
  detail_ += " frame pairs with boards";
  return true;
}

bool SessionMachine::CoverageMet() const {
  const CaptureCoverage c = Coverage();
  return c.frames_with_boards >= c.gates.min_frames && c.boards >= c.gates.min_boards &&
         DistanceBinsSeen(c) >= c.gates.min_distance_bins &&
         ImageCellsSeen(c) >= c.gates.min_image_cells;
}

void SessionMachine::CheckCollectionEnd(int64_t now_us) {
  UpdateProgress(now_us);
  if (figures_.frames_with_boards >= config_.gates.target_frames) {
    EnterSolving(CollectionEnd::kTargetFrames);
    return;
  }
  if (config_.stop_on_coverage && CoverageMet()) {
    EnterSolving(CollectionEnd::kCoverage);
    return;
  }
  if (CheckSensorTimeout(now_us)) return;
  if (now_us - started_us_ < limit_us_) return;
  FinishCollection(CollectionEnd::kTimeLimit);
}

void SessionMachine::EndOfData(int64_t now_us) {
  if (state_ != SessionState::kCollecting) return;
  UpdateProgress(now_us);
  FinishCollection(CollectionEnd::kEndOfData);
}

void SessionMachine::FinishCollection(CollectionEnd end) {
  collection_end_ = end;
  const bool frames_short = figures_.frames_with_boards < config_.gates.min_frames;
  if (!frames_short && figures_.boards >= config_.gates.min_boards) {
    EnterSolving(end);
    return;
  }
  const bool no_camera = last_camera_us_ == 0, no_lidar = last_lidar_us_ == 0;
  if (frames_short && no_camera != no_lidar) {
    // Nothing could pair: name the sensor that sent nothing rather than the frames it cost.
    EnterFailed(no_lidar ? Reason::kLidarTimeout : Reason::kCameraTimeout);
    detail_ = no_lidar ? "LiDAR: no frame in this session, the camera sent ("
                       : "camera: no frame in this session, the LiDAR sent (";
    detail_ += CollectionEndName(end);
    detail_ += ")";
    return;
  }
  EnterFailed(frames_short ? Reason::kTooFewFrames : Reason::kTooFewBoards);
  if (end == CollectionEnd::kTimeLimit) {
    detail_ = "time limit (";
    const bool whole_seconds = limit_us_ % 1000000 == 0;
    AppendInt(&detail_, whole_seconds ? limit_us_ / 1000000 : limit_us_ / 1000);
    detail_ += whole_seconds ? " s) reached with " : " ms) reached with ";
  } else {
    detail_ = "input ended with ";
  }
  AppendInt(&detail_, frames_short ? figures_.frames_with_boards : figures_.boards);
  detail_ += frames_short ? " frame pairs with boards, " : " board observations, ";
  AppendInt(&detail_, frames_short ? config_.gates.min_frames : config_.gates.min_boards);
  detail_ += " needed";
}

void SessionMachine::EnterSolving(CollectionEnd end) {
  collection_end_ = end;
  state_ = SessionState::kSolving;
  solve_pending_ = true;
  progress_ = std::max(progress_, kCollectingShare);
  UpdateGuidance();
}

void SessionMachine::EnterFailed(Reason reason) {
  state_ = SessionState::kFailed;
  solve_pending_ = false;
  reason_ = reason;
  detail_.clear();
  UpdateGuidance();
}

void SessionMachine::UpdateProgress(int64_t now_us) {
  const double frames = static_cast<double>(figures_.frames_with_boards) /
                        static_cast<double>(std::max(1, config_.gates.target_frames));
  // A clock that steps back (it should not: monotonic) counts as no time passed.
  const double time = static_cast<double>(std::max<int64_t>(0, now_us - started_us_)) /
                      static_cast<double>(std::max<int64_t>(1, limit_us_));
  progress_ = std::max(progress_, kCollectingShare * std::clamp(std::max(frames, time), 0.0, 1.0));
}

bool SessionMachine::NeedsSolve() {
  const bool pending = solve_pending_;
  solve_pending_ = false;
  return pending;
}

bool SessionMachine::SolveFinished(int session, CalibrationOutcome::Verdict verdict, Reason reason,
                                   const std::string& detail) {
  if (session != session_ || state_ != SessionState::kSolving) return false;
  solve_pending_ = false;
  verdict_ = verdict;
  reason_ = reason;
  detail_ = detail;
  state_ = SessionState::kDone;
  progress_ = 1.0;
  UpdateGuidance();
  return true;
}

bool SessionMachine::SolveFailed(int session, Reason reason, const std::string& detail) {
  if (session != session_ || state_ != SessionState::kSolving) return false;
  EnterFailed(reason);
  detail_ = detail;
  return true;
}

RequestReply SessionMachine::CommitRequested() {
  RequestReply reply;
  if (state_ != SessionState::kDone) {
    reply.reason = std::string("no finished session to commit (") + SessionStateName(state_) + ")";
  } else if (verdict_ != CalibrationOutcome::Verdict::kUpdated) {
    reply.reason = std::string("nothing to commit: the verdict was ") + VerdictName(verdict_) +
                   (verdict_ == CalibrationOutcome::Verdict::kVerified
                        ? " (the stored calibration stands)"
                        : " (" + std::string(NameOf(reason_)) + ")");
  } else if (request_.verify_only) {
    reply.reason = "verify-only session: its result is not committed";
  } else if (committed_) {
    reply.reason = "already committed";
  } else {
    committed_ = true;
    reply.accepted = true;
    if (commit_failed()) {  // retried: the failure is no longer the news
      reason_ = Reason::kNone;
      detail_.clear();
    }
    UpdateGuidance();
  }
  return reply;
}

void SessionMachine::CommitFailed(const std::string& detail) {
  if (state_ != SessionState::kDone || !committed_) return;
  committed_ = false;
  reason_ = Reason::kCommitFailed;
  detail_ = detail;
  UpdateGuidance();
}

CaptureCoverage SessionMachine::Coverage() const {
  CaptureCoverage c;
  c.moving = request_.mode == SessionMode::kMoving;
  c.distance_bins = figures_.distance_bins;
  c.image_cells = figures_.image_cells;
  c.frames_with_boards = figures_.frames_with_boards;
  c.boards = figures_.boards;
  c.gates = config_.gates;
  return c;
}

void SessionMachine::UpdateGuidance() {
  guidance_.clear();
  if (state_ == SessionState::kDone) {
    if (verdict_ == CalibrationOutcome::Verdict::kUpdated && !committed_ && !request_.verify_only)
      guidance_ = "new calibration ready: send COMMIT to store it";
    return;
  }
  if (state_ != SessionState::kCollecting) return;
  AppendCaptureGuidance(Coverage(), &guidance_);
}

}  // namespace calibd
