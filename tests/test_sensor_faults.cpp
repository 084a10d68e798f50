// Sensor faults: a simulated drive goes through the agent's per-frame path as
// calibd-agent composes it (agent/src/agent.cpp: OnCamera/OnLidar tell the SessionMachine a frame
// arrived and hand it to the FrameIntake; Step drains the detected pairs into the SessionRecorder
// and reports them to the machine, ticks it every 50 ms, deactivates the intake once the
// collection ended and logs malformed messages through a RateLimitedLog) while the sensors
// misbehave: a sensor stops, pauses and restarts, sends frames out of order or twice, its clock
// jumps, or it runs at 3x its rate. Each case checks the outcome (a calibration within the
// verification tolerances of the truth, or kFailed with the reason naming the sensor and the
// fault), the per-sensor counters with exact counts, and that the fault costs no allocation (the
// intake's slots and the session store are fixed; counting_new.hpp counts operator new on every
// thread).
//
// The clock is simulated: the drive's 80 pairs (4 Hz, as test_agent_replay) arrive on a fixed
// schedule of the agent's monotonic time, kPeriodUs apart, the camera frame 60 ms and the sweep
// 120 ms (its end, plus transport) into the period; the poll loop's timer ticks every 50 ms. The
// intake is drained after every message (as a replay waits for the detectors), so no pair is
// dropped for lack of a slot and every count is exact.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <string>
#include <thread>
#include <vector>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/rate_limited_log.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/agent/session_recorder.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "counting_new.hpp"
#include "short_session.hpp"
#include "simulated_messages.hpp"
#include "small_camera.hpp"

namespace calibd {
namespace {

constexpr int kPairs = 80;
constexpr int64_t kPeriodUs = 250000;  // 4 Hz
constexpr int64_t kT0 = 1000000000;    // monotonic time of the first period
constexpr int64_t kTickUs = 50000;     // the agent's poll loop timer
constexpr int64_t kTimeoutUs = SessionConfig{}.sensor_timeout_us;

using Drive = testing::SimulatedMessages;

// A drive 3-9 m and back in 20 s (as far as the small camera's tags measure their distance well
// enough) at 4 Hz, small camera, m1 LiDAR: simulated once.
const Drive& SimulatedDrive() {
  static const Drive d = [] {
    sim::SessionOptions options;
    options.seed = 7;
    options.lidar_model = "m1";
    options.camera = testing::SmallCamera();
    options.trajectory.rate_hz = 1e6 / static_cast<double>(kPeriodUs);
    options.trajectory.min_distance_m = 3.0;
    options.trajectory.max_distance_m = 9.0;
    Drive out = testing::SimulateMessages(options, kPairs);
    EXPECT_EQ(out.drive_frames, kPairs) << "the whole drive, 3-9 m and back";
    return out;
  }();
  return d;
}

// Arrival of pair i's messages on the agent's monotonic clock (a sender's clock may jump, this
// one does not).
int64_t CameraArrival(int i) { return kT0 + i * kPeriodUs + 60000; }
int64_t LidarArrival(int i) { return kT0 + i * kPeriodUs + 120000; }

// The agent's per-frame path with a simulated clock.
class Rig {
 public:
  explicit Rig(const Drive& drive) : drive_(drive) {
    config_.calib = drive.config;
    config_.stop_on_coverage = false;  // collect the whole drive unless a fault ends it
    config_.target_frames = 100000;
    config_.max_duration_s = 3600.0;
    // The small camera's 80-pair drive: the short session's tolerances (short_session.hpp).
    config_.engine = testing::ShortSessionEngine();
    std::string error;
    EXPECT_TRUE(config_.IsValid(&error)) << error;
    EXPECT_TRUE(intake_.Init(IntakeConfigFrom(config_), config_.calib, &error)) << error;
    EXPECT_TRUE(intake_.AwaitStartup()) << intake_.startup().error;
    recorder_.Init(config_);
    machine_ = SessionMachine(SessionConfigFrom(config_));
    StartRequest request;
    request.requester = "test_sensor_faults";
    EXPECT_TRUE(machine_.Start(request, kT0).accepted);
    recorder_.Clear();
    intake_.SetActive(true);
  }

  // Agent::OnCamera / OnLidar at `arrival_us`, after the timer ticks before it.
  void Camera(const camera_frame_t& m, int64_t arrival_us) {
    AdvanceTo(arrival_us);
    machine_.FrameArrived(SensorStream::kCamera, now_);
    intake_.OnCamera(m);
    Step();
  }
  void Lidar(const lidar_frame_t& m, int64_t arrival_us) {
    AdvanceTo(arrival_us);
    machine_.FrameArrived(SensorStream::kLidar, now_);
    const int64_t pairs_formed = intake_.counters().pairs_formed;
    intake_.OnLidar(m);
    if (intake_.counters().pairs_formed > pairs_formed) machine_.PairFormed(now_);
    Step();
  }
  void Pair(int i) {
    Camera(drive_.camera[static_cast<size_t>(i)], CameraArrival(i));
    Lidar(drive_.lidar[static_cast<size_t>(i)], LidarArrival(i));
  }
  // Pairs [begin, end), except that `silent` sends nothing for the pairs [silent_from,
  // silent_to): only the other sensor's frames arrive then.
  void PairsWithSilence(int begin, int end, SensorStream silent, int silent_from, int silent_to) {
    for (int i = begin; i < end; ++i) {
      if (i < silent_from || i >= silent_to)
        Pair(i);
      else if (silent == SensorStream::kLidar)
        Camera(drive_.camera[static_cast<size_t>(i)], CameraArrival(i));
      else
        Lidar(drive_.lidar[static_cast<size_t>(i)], LidarArrival(i));
    }
  }

  // The timer's ticks up to `t_us` (each a Step), then the clock at `t_us`.
  void AdvanceTo(int64_t t_us) {
    while (next_tick_ <= t_us) {
      now_ = next_tick_;
      next_tick_ += kTickUs;
      Step();
    }
    now_ = t_us;
  }

  // The end of the replayed data (Agent::Step with end_of_log_): what is left is solved.
  void EndOfData() {
    Step();
    machine_.EndOfData(now_);
    Step();
  }

  // The collecting part of Agent::Step (after the intake finished what it holds, as a replay
  // waits for it) and the malformed-message log.
  void Step() {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(30);
    if (hold_detections_) {  // detection lags: nothing is drained
      machine_.Tick(now_);
      if (machine_.state() != SessionState::kCollecting && intake_.active()) {
        intake_.SetActive(false);
        ended_us_ = now_;
      }
      return;
    }
    for (;;) {
      if (machine_.state() == SessionState::kCollecting) {
        if (recorder_.DrainFrom(&intake_) > 0) machine_.FrameRecorded(recorder_.figures(), now_);
      } else {
        intake_.Drain(nullptr);
      }
      if (intake_.Idle() || std::chrono::steady_clock::now() > deadline) break;
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    machine_.Tick(now_);
    if (machine_.state() != SessionState::kCollecting && intake_.active()) {
      intake_.SetActive(false);
      ended_us_ = now_;
    }
    int64_t since_last = 0;
    const IntakeCounters& c = intake_.counters();
    if (malformed_log_.Due(c.bad_messages, now_, &since_last))
      log_.push_back(MalformedMessagesLine(since_last, c.bad_messages, c.last_error));
  }

  // Agent::StartSolve's call, on this thread: the verdict goes to the machine.
  CalibrationOutcome Solve() {
    EXPECT_TRUE(machine_.NeedsSolve());
    const RangeImage projection = SessionProjection(drive_.lidar_model);
    const CalibrationOutcome o =
        Calibrate(config_.calib, recorder_.session(), projection, config_.engine);
    machine_.SolveFinished(machine_.session(), o.verdict, o.reason, o.detail);
    return o;
  }

  // Solves and requires the truth within the verification tolerances (the small camera's near
  // boards give a little less rotation than test_agent_replay's full-size drive).
  // `bound_may_refuse`: the session keeps few enough pairs that its own error bound may lie
  // beyond the accuracy a result must be known to, refused as `poor_observability` (the truth
  // still within the verification tolerances).
  void ExpectCorrectCalibration(bool bound_may_refuse = false) {
    ASSERT_EQ(machine_.state(), SessionState::kSolving) << machine_.reason() << machine_.detail();
    const CalibrationOutcome o = Solve();
    if (bound_may_refuse && o.verdict == CalibrationOutcome::Verdict::kRejected) {
      EXPECT_EQ(o.reason, Reason::kPoorObservability) << o.detail;
      EXPECT_NE(o.detail.find("its 99 % bound"), std::string::npos) << o.detail;
    } else {
      EXPECT_EQ(o.verdict, CalibrationOutcome::Verdict::kUpdated) << o.reason << ": " << o.detail;
    }
    const double rot_deg =
        RotationAngle(o.T_camera_lidar.linear(), drive_.T_camera_lidar.linear()) * kRad2Deg;
    const double trans_m =
        (o.T_camera_lidar.translation() - drive_.T_camera_lidar.translation()).norm();
    EXPECT_LT(rot_deg, VerdictConfig{}.verify_rotation_deg);
    EXPECT_LT(trans_m, VerdictConfig{}.verify_translation_m);
    std::printf("calibration error %.4f deg, %.4f m from %d pairs\n", rot_deg, trans_m,
                recorder_.session().num_frames);
  }

  // While held, Step drains nothing: the pairs wait in the intake (or are dropped once every
  // slot is busy), as when detection runs slower than the sensors on a loaded CPU.
  void HoldDetections(bool hold) { hold_detections_ = hold; }

  const IntakeCounters& counters() const { return intake_.counters(); }
  const SessionMachine& machine() const { return machine_; }
  const CollectionFigures& figures() const { return recorder_.figures(); }
  const std::vector<std::string>& log() const { return log_; }
  int64_t now() const { return now_; }
  int64_t ended_us() const { return ended_us_; }  ///< tick at which the collection ended

 private:
  const Drive& drive_;
  AgentConfig config_;
  FrameIntake intake_;
  SessionRecorder recorder_;
  SessionMachine machine_{SessionConfig{}};
  RateLimitedLog malformed_log_;
  std::vector<std::string> log_;
  int64_t now_ = kT0, next_tick_ = kT0, ended_us_ = 0;
  bool hold_detections_ = false;
};

// The pairs before a fault, so that every intake slot, the detectors' scratch and the session
// store have reached their steady size; the fault's own pairs are then counted.
constexpr int kWarmup = 20;

std::string TimeoutDetail(const char* who, int frames_with_boards) {
  return std::string(who) + ": no frame for more than 2000 ms while collecting, " +
         std::to_string(frames_with_boards) + " frame pairs with boards";
}

// (a) The LiDAR stops after 30 sweeps, the camera goes on: 2 s after the last sweep (at the next
// tick) the session fails naming the LiDAR; 30 pairs are too few to solve.
TEST(SensorFaultsTest, LidarStopsMidSession) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int kStop = 30;
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  rig.PairsWithSilence(kWarmup, kPairs, SensorStream::kLidar, kStop, kPairs);
  EXPECT_EQ(testing::Allocations() - news, 0);
  const SessionMachine& m = rig.machine();
  ASSERT_EQ(m.state(), SessionState::kFailed);
  EXPECT_EQ(m.reason(), Reason::kLidarTimeout);
  EXPECT_EQ(m.detail(), TimeoutDetail("LiDAR", m.figures().frames_with_boards));
  EXPECT_EQ(m.collection_end(), CollectionEnd::kSensorTimeout);
  // Failed at the first tick more than 2 s after the last sweep arrived.
  EXPECT_GT(rig.ended_us() - LidarArrival(kStop - 1), kTimeoutUs);
  EXPECT_LE(rig.ended_us() - LidarArrival(kStop - 1), kTimeoutUs + kTickUs);
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.camera_frames, kPairs);  // counted whether collecting or not
  EXPECT_EQ(c.lidar_frames, kStop);
  EXPECT_EQ(c.pairs_detected, kStop);
  // Camera frames 30..37 arrived before the failure (37 at 2.19 s after the last sweep's 0.12 s
  // into period 29, the failing tick at 2.40 s): each displaced by the next, 37 still waiting
  // when the intake stopped; 38.. are ignored.
  EXPECT_EQ(c.unpaired_camera, 7);
  EXPECT_EQ(c.ignored_inactive, kPairs - kStop - 8);
  EXPECT_EQ(c.unpaired_lidar + c.camera_missed + c.lidar_missed + c.out_of_order, 0);
  EXPECT_EQ(c.dropped_queue_full + c.bad_messages, 0);
}

// (b) The camera stops after 60 frames, the LiDAR goes on: with enough pairs the collection ends
// (sensor_timeout) and what was collected is solved.
TEST(SensorFaultsTest, CameraStopsMidSessionAfterEnoughPairs) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int kStop = 60;
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  rig.PairsWithSilence(kWarmup, kPairs, SensorStream::kCamera, kStop, kPairs);
  EXPECT_EQ(testing::Allocations() - news, 0);
  EXPECT_EQ(rig.machine().collection_end(), CollectionEnd::kSensorTimeout);
  EXPECT_GT(rig.ended_us() - CameraArrival(kStop - 1), kTimeoutUs);
  EXPECT_LE(rig.ended_us() - CameraArrival(kStop - 1), kTimeoutUs + kTickUs);
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.camera_frames, kStop);
  EXPECT_EQ(c.lidar_frames, kPairs);
  EXPECT_EQ(c.pairs_detected, kStop);
  // Sweeps 60..66 arrived before the end (66 at 1.81 s after the last camera frame's 0.06 s
  // into period 59, the ending tick at 2.04 s).
  EXPECT_EQ(c.unpaired_lidar, 7);
  EXPECT_EQ(c.unpaired_camera + c.camera_missed + c.lidar_missed + c.out_of_order, 0);
  rig.ExpectCorrectCalibration();
}

// A sensor that sends nothing at all while the other does: the session cannot pair a frame and
// fails at the end of the data naming it (not "too_few_frames").
TEST(SensorFaultsTest, ASensorThatNeverSendsIsNamed) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  for (int i = 0; i < 10; ++i) rig.Camera(d.camera[static_cast<size_t>(i)], CameraArrival(i));
  rig.EndOfData();
  EXPECT_EQ(rig.machine().state(), SessionState::kFailed);
  EXPECT_EQ(rig.machine().reason(), Reason::kLidarTimeout);
  EXPECT_EQ(rig.machine().detail(),
            "LiDAR: no frame in this session, the camera sent (end_of_data)");
  EXPECT_EQ(rig.counters().unpaired_camera, 9);
}

// (c) The LiDAR pauses for 1.5 s (6 sweeps) and resumes: shorter than the timeout, so the
// session goes on; the 6 sweeps are counted missing (a gap, not a restart) and their camera
// frames unpaired.
TEST(SensorFaultsTest, LidarPausesAndResumes) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int kPauseFrom = 40, kPauseTo = 46;
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  rig.PairsWithSilence(kWarmup, kPairs, SensorStream::kLidar, kPauseFrom, kPauseTo);
  EXPECT_EQ(testing::Allocations() - news, 0);
  ASSERT_EQ(rig.machine().state(), SessionState::kCollecting) << rig.machine().detail();
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.lidar_frames, kPairs - 6);
  EXPECT_EQ(c.lidar_missed, 6);
  EXPECT_EQ(c.lidar_restarts, 0);
  EXPECT_EQ(c.camera_missed, 0);
  EXPECT_EQ(c.unpaired_camera, 6);
  EXPECT_EQ(c.pairs_detected, kPairs - 6);
  // Every sweep the LiDAR sent is accounted for: received + missing.
  EXPECT_EQ(c.lidar_frames + c.lidar_missed, kPairs);
  rig.ExpectCorrectCalibration();
}

// (d) Camera frames 10, 30 and 50 are delayed past the next one: each is late (skipped as out of
// order, not paired with a sweep it does not belong to) and its slot in the stream was counted
// missing when the next frame came; the sweep it belonged to went unpaired.
TEST(SensorFaultsTest, OutOfOrderCameraFramesAreSkippedAndCounted) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  for (int i = kWarmup; i < kPairs; ++i) {
    if (i % 20 == 10) {  // camera i arrives just after camera i + 1
      rig.Lidar(d.lidar[static_cast<size_t>(i)], LidarArrival(i));
      rig.Camera(d.camera[static_cast<size_t>(i + 1)], CameraArrival(i + 1));
      rig.Camera(d.camera[static_cast<size_t>(i)], CameraArrival(i + 1) + 1000);
      rig.Lidar(d.lidar[static_cast<size_t>(i + 1)], LidarArrival(i + 1));
      ++i;
    } else {
      rig.Pair(i);
    }
  }
  // 0..19 were the warm-up: only 30 and 50 fall in the counted part, 10 before it.
  EXPECT_EQ(testing::Allocations() - news, 0);
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  constexpr int kLate = 3;  // frames 10, 30, 50
  EXPECT_EQ(c.camera_frames, kPairs);
  EXPECT_EQ(c.camera_late, kLate);
  EXPECT_EQ(c.camera_missed, kLate);
  EXPECT_EQ(c.out_of_order, kLate);
  EXPECT_EQ(c.unpaired_lidar, kLate);
  EXPECT_EQ(c.pairs_detected, kPairs - kLate);
  EXPECT_EQ(c.camera_duplicates + c.lidar_late + c.unpaired_camera, 0);
  // Frames sent = received + missing - late.
  EXPECT_EQ(c.camera_frames + c.camera_missed - c.camera_late, kPairs);
  rig.ExpectCorrectCalibration();
}

// (e) Every 5th camera frame and every 7th sweep arrive twice: the copy is counted as a duplicate
// (not a second frame of the stream, nor a second pair) and skipped.
TEST(SensorFaultsTest, DuplicatedFramesAreCountedOnceAndSkipped) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  int camera_copies = 0, lidar_copies = 0;
  for (int i = 0; i < kPairs; ++i) {
    rig.Camera(d.camera[static_cast<size_t>(i)], CameraArrival(i));
    if (i % 5 == 0) {
      rig.Camera(d.camera[static_cast<size_t>(i)], CameraArrival(i) + 1000);
      ++camera_copies;
    }
    rig.Lidar(d.lidar[static_cast<size_t>(i)], LidarArrival(i));
    if (i % 7 == 0) {
      rig.Lidar(d.lidar[static_cast<size_t>(i)], LidarArrival(i) + 1000);
      ++lidar_copies;
    }
  }
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(camera_copies, 16);
  EXPECT_EQ(lidar_copies, 12);
  EXPECT_EQ(c.camera_frames, kPairs + camera_copies);
  EXPECT_EQ(c.lidar_frames, kPairs + lidar_copies);
  EXPECT_EQ(c.camera_duplicates, camera_copies);
  EXPECT_EQ(c.lidar_duplicates, lidar_copies);
  EXPECT_EQ(c.out_of_order, camera_copies + lidar_copies);
  EXPECT_EQ(c.pairs_detected, kPairs);
  EXPECT_EQ(c.camera_missed + c.lidar_missed + c.unpaired_camera + c.unpaired_lidar, 0);
  EXPECT_EQ(c.camera_frames - c.camera_duplicates, kPairs);
  rig.ExpectCorrectCalibration();
}

// A sender whose clock stepped: its messages with their capture times shifted, copied into
// buffers reserved for the largest of the drive, so that the test's own copies allocate nothing
// while the agent's path is counted.
class ShiftedCopies {
 public:
  explicit ShiftedCopies(const Drive& d) {
    size_t bytes = 0, points = 0;
    for (const auto& c : d.camera) bytes = std::max(bytes, c.data.size());
    for (const auto& l : d.lidar) points = std::max(points, l.x.size());
    camera_.data.reserve(bytes);
    for (auto* v : {&lidar_.x, &lidar_.y, &lidar_.z, &lidar_.intensity}) v->reserve(points);
    lidar_.ring.reserve(points);
    lidar_.time_offset_us.reserve(points);
  }
  const camera_frame_t& Camera(const camera_frame_t& m, int64_t by_us) {
    camera_ = m;
    camera_.utime += by_us;
    return camera_;
  }
  const lidar_frame_t& Lidar(const lidar_frame_t& m, int64_t by_us) {
    lidar_ = m;
    lidar_.utime += by_us;
    return lidar_;
  }

 private:
  camera_frame_t camera_;
  lidar_frame_t lidar_;
};

// (f) Both sensors' clocks (one time source, e.g. PTP) step back a minute at pair 40 and forward
// 30 s at pair 60: each step is a restart of both streams, not lost frames, and the pairing
// follows the new timeline (before, every frame after the step back was refused as out of order
// until the old time came round again: no pair for a minute).
TEST(SensorFaultsTest, ClockStepsBackAndForwardOnBothSensors) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int64_t kBackUs = -60000000, kForwardUs = 30000000;
  ShiftedCopies shifted(d);
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  for (int i = kWarmup; i < kPairs; ++i) {
    const int64_t shift = i < 40 ? 0 : i < 60 ? kBackUs : kBackUs + kForwardUs;
    rig.Camera(shifted.Camera(d.camera[static_cast<size_t>(i)], shift), CameraArrival(i));
    rig.Lidar(shifted.Lidar(d.lidar[static_cast<size_t>(i)], shift), LidarArrival(i));
  }
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.camera_restarts, 2);
  EXPECT_EQ(c.lidar_restarts, 2);
  EXPECT_EQ(c.pairs_detected, kPairs);
  EXPECT_EQ(c.out_of_order + c.camera_late + c.lidar_late, 0);
  EXPECT_EQ(c.camera_missed + c.lidar_missed + c.unpaired_camera + c.unpaired_lidar, 0);
  EXPECT_EQ(testing::Allocations() - news, 0);
  rig.ExpectCorrectCalibration();
}

// (f) The camera's clock alone jumps 10 s ahead at pair 30: its frames no longer pair with any
// sweep although both sensors keep sending; 2 s after the last pair the session fails with
// no_pairs (30 pairs are too few to solve).
TEST(SensorFaultsTest, CameraClockJumpAheadAloneFailsWithNoPairs) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int kJump = 30;
  ShiftedCopies shifted(d);
  for (int i = 0; i < kWarmup; ++i) rig.Pair(i);
  const long news = testing::Allocations();
  for (int i = kWarmup; i < kPairs; ++i) {
    const int64_t shift = i < kJump ? 0 : 10000000;
    rig.Camera(shifted.Camera(d.camera[static_cast<size_t>(i)], shift), CameraArrival(i));
    rig.Lidar(d.lidar[static_cast<size_t>(i)], LidarArrival(i));
  }
  EXPECT_EQ(testing::Allocations() - news, 0);
  const SessionMachine& m = rig.machine();
  ASSERT_EQ(m.state(), SessionState::kFailed);
  EXPECT_EQ(m.reason(), Reason::kNoPairs);
  EXPECT_EQ(m.detail(),
            "camera and LiDAR: both sending, but no frame pair for more than 2000 ms while "
            "collecting (their capture times do not pair, or every pair was malformed), " +
                std::to_string(m.figures().frames_with_boards) + " frame pairs with boards");
  // The last pair was recorded when sweep 29 arrived.
  EXPECT_GT(rig.ended_us() - LidarArrival(kJump - 1), kTimeoutUs);
  EXPECT_LE(rig.ended_us() - LidarArrival(kJump - 1), kTimeoutUs + kTickUs);
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.camera_restarts, 1);
  EXPECT_EQ(c.lidar_restarts, 0);
  EXPECT_EQ(c.pairs_detected, kJump);
  // Before the failing tick (2.03 s after sweep 29): sweeps 30..37 unpaired, camera frames
  // 30..37 each displaced by the next but the last, which was waiting when the intake stopped.
  EXPECT_EQ(c.unpaired_lidar, 8);
  EXPECT_EQ(c.unpaired_camera, 7);
  EXPECT_EQ(c.camera_missed + c.lidar_missed + c.out_of_order, 0);
}

// (f2) Detection lags 5 s behind healthy streams (a loaded CPU): no pair reaches the session for
// twice the sensor timeout, but the streams keep pairing, so the collection goes on (the pairs
// that found no free slot meanwhile are counted dropped) and the drive calibrates.
TEST(SensorFaultsTest, DetectionLaggingBeyondTheSensorTimeoutIsNotNoPairs) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int kLagFrom = kWarmup, kLagTo = kWarmup + 20;  // 20 periods: 5 s
  static_assert((kLagTo - kLagFrom) * kPeriodUs > 2 * kTimeoutUs, "longer than the timeout");
  for (int i = 0; i < kLagFrom; ++i) rig.Pair(i);
  rig.HoldDetections(true);
  for (int i = kLagFrom; i < kLagTo; ++i) rig.Pair(i);
  ASSERT_EQ(rig.machine().state(), SessionState::kCollecting)
      << rig.machine().reason() << ": " << rig.machine().detail();
  rig.HoldDetections(false);
  for (int i = kLagTo; i < kPairs; ++i) rig.Pair(i);
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.pairs_formed, kPairs);
  EXPECT_GT(c.dropped_queue_full, 0) << "the lag outlasts the intake's slots";
  EXPECT_EQ(c.pairs_detected + c.dropped_queue_full, kPairs);
  // 65 of the 80 pairs of the small camera's drive: its principal point read from the tags
  // without their corner bias (docs/error-bound.md) may take the bound over 0.30 deg.
  rig.ExpectCorrectCalibration(/*bound_may_refuse=*/true);
}

// (g) The camera runs at 3x its rate (12 Hz against the LiDAR's 4 Hz pairs): each sweep pairs
// with the camera frame captured during it, the two in between are unpaired, no frame counts as
// missing (the period is learnt from the stream), and the session calibrates as at 1x.
TEST(SensorFaultsTest, CameraAtThreeTimesItsRate) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  constexpr int64_t kThird = kPeriodUs / 3;
  ShiftedCopies shifted(d);
  long news = 0;
  for (int i = 0; i < kPairs; ++i) {
    if (i == kWarmup) news = testing::Allocations();
    rig.Pair(i);
    if (i + 1 == kPairs) break;
    // Two more frames between this pair's and the next (their images: this frame's; they never
    // pair, so their content does not matter).
    for (int k = 1; k <= 2; ++k)
      rig.Camera(shifted.Camera(d.camera[static_cast<size_t>(i)], k * kThird),
                 CameraArrival(i) + k * kThird);
  }
  EXPECT_EQ(testing::Allocations() - news, 0);
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(c.camera_frames, kPairs + 2 * (kPairs - 1));
  EXPECT_EQ(c.lidar_frames, kPairs);
  EXPECT_EQ(c.unpaired_camera, 2 * (kPairs - 1));
  EXPECT_EQ(c.pairs_detected, kPairs);
  EXPECT_EQ(c.camera_missed + c.lidar_missed + c.unpaired_lidar + c.out_of_order, 0);
  rig.ExpectCorrectCalibration();
}

// Malformed messages: counted and skipped, the session goes on, and logged as the first one at
// once and then one line per 10 s with the count.
TEST(SensorFaultsTest, MalformedMessagesAreCountedAndLoggedRateLimited) {
  const Drive& d = SimulatedDrive();
  Rig rig(d);
  // From pair 20 to 59 (10 s), every 4th camera frame lies about its size (found in the worker)
  // and every 4th sweep's arrays are shorter than num_points (found before the copy).
  int bad_camera = 0, bad_lidar = 0;
  for (int i = 0; i < kPairs; ++i) {
    camera_frame_t camera = d.camera[static_cast<size_t>(i)];
    lidar_frame_t lidar = d.lidar[static_cast<size_t>(i)];
    const bool faulty = i >= 20 && i < 60;
    if (faulty && i % 4 == 0) {
      camera.size = 7;
      ++bad_camera;
    } else if (faulty && i % 4 == 2) {
      lidar.y.pop_back();
      ++bad_lidar;
    }
    if (i == 70) {
      // NaN points (a return that did not come back): not malformed, skipped by the detector.
      for (size_t p = 0; p < lidar.x.size(); p += 10) lidar.x[p] = std::nanf("");
    }
    rig.Camera(camera, CameraArrival(i));
    rig.Lidar(lidar, LidarArrival(i));
  }
  rig.EndOfData();
  const IntakeCounters& c = rig.counters();
  EXPECT_EQ(bad_camera, 10);
  EXPECT_EQ(bad_lidar, 10);
  EXPECT_EQ(c.bad_messages, bad_camera + bad_lidar);
  EXPECT_EQ(c.pairs_detected, kPairs - bad_camera - bad_lidar);
  // A sweep refused before pairing leaves its camera frame waiting, displaced by the next.
  EXPECT_EQ(c.unpaired_camera, bad_lidar);
  EXPECT_EQ(rig.machine().state(), SessionState::kSolving);
  // The first at once (pair 20's camera frame, found when its pair is drained at 5.12 s), then
  // nothing until 10 s later, when one line sums up the 19 others (the last at 14.37 s); none
  // after, as none came.
  const std::vector<std::string>& log = rig.log();
  ASSERT_EQ(log.size(), 2u);
  EXPECT_EQ(log[0], "malformed message skipped: camera_frame_t: size 7 does not match " +
                        std::to_string(d.camera[20].data.size()) + " data bytes (1 in all)");
  EXPECT_EQ(log[1],
            "19 malformed messages skipped (20 in all), latest: lidar_frame_t: array "
            "lengths differ from num_points " +
                std::to_string(d.lidar[58].num_points));
  rig.ExpectCorrectCalibration();
}

}  // namespace
}  // namespace calibd
