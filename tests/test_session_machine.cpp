#include "calibd/agent/session_machine.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <limits>
#include <new>
#include <random>

#include "counting_new.hpp"  // counts every operator new of the process

namespace calibd {
namespace {

constexpr int64_t kS = 1000 * 1000;  // us per s
constexpr int64_t kT0 = 5000 * kS;   // an arbitrary monotonic start time

SessionConfig TestConfig() {
  SessionConfig c;
  c.gates.target_frames = 100;
  c.gates.min_frames = 20;
  c.gates.min_boards = 30;
  c.max_duration_us = 60 * kS;
  c.gates.min_distance_bins = 3;
  c.gates.min_image_cells = 4;
  c.stop_on_coverage = true;
  return c;
}

CollectionFigures Figures(int frames, int boards, uint32_t bins = 0, uint32_t cells = 0) {
  CollectionFigures f;
  f.frames_with_boards = frames;
  f.boards = boards;
  f.distance_bins = bins;
  f.image_cells = cells;
  return f;
}

constexpr uint32_t kThreeBins = 0b0111;
constexpr uint32_t kFourCells = 0b1000'0100'0010'0001;  // one cell in each image row

StartRequest Request(const std::string& requester = "tester") {
  StartRequest r;
  r.requester = requester;
  return r;
}

// A machine whose session 1 has collected its target and waits for the solve.
SessionMachine Solving(const SessionConfig& config = TestConfig()) {
  SessionMachine m(config);
  EXPECT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(config.gates.target_frames, 300, 0b1111, 0xffff), kT0 + kS));
  EXPECT_EQ(m.state(), SessionState::kSolving);
  return m;
}

TEST(SessionMachineTest, StartsIdle) {
  SessionMachine m(TestConfig());
  EXPECT_EQ(m.state(), SessionState::kIdle);
  EXPECT_EQ(m.session(), 0);
  EXPECT_EQ(m.progress(), 0.0);
  EXPECT_FALSE(m.NeedsSolve());
  EXPECT_TRUE(m.guidance().empty());
  EXPECT_TRUE(m.reason() == Reason::kNone);
  EXPECT_FALSE(m.FrameRecorded(Figures(1, 1), kT0)) << "no session: frames are ignored";
  m.Tick(kT0 + 1000 * kS);
  EXPECT_EQ(m.state(), SessionState::kIdle);
}

TEST(SessionMachineTest, StartBeginsCollectingWithTheConfiguredOrRequestedLimit) {
  SessionMachine m(TestConfig());
  const RequestReply reply = m.Start(Request("eol-station-3"), kT0);
  EXPECT_TRUE(reply.accepted);
  EXPECT_TRUE(reply.reason.empty());
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_EQ(m.session(), 1);
  EXPECT_EQ(m.started_us(), kT0);
  EXPECT_EQ(m.limit_us(), 60 * kS);
  EXPECT_EQ(m.request().requester, "eol-station-3");
  EXPECT_EQ(m.guidance(), "no board seen yet: drive towards the boards");

  SessionMachine s(TestConfig());
  StartRequest r = Request();
  r.mode = SessionMode::kStatic;
  r.max_duration_us = 10 * kS;
  ASSERT_TRUE(s.Start(r, kT0).accepted);
  EXPECT_EQ(s.limit_us(), 10 * kS);
  EXPECT_EQ(s.guidance(), "no board seen yet: place the boards in view of both sensors");
}

TEST(SessionMachineTest, StartRefusedWhileASessionRuns) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request("tester"), kT0).accepted);
  RequestReply reply = m.Start(Request("cli"), kT0 + kS);
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason,
            "recalibration in progress (session 1 collecting, requested by 'tester')");
  EXPECT_EQ(m.session(), 1);
  EXPECT_EQ(m.request().requester, "tester");

  SessionMachine s = Solving();
  reply = s.Start(Request(), kT0 + 2 * kS);
  EXPECT_FALSE(reply.accepted);
  EXPECT_NE(reply.reason.find("recalibration in progress"), std::string::npos) << reply.reason;
  EXPECT_EQ(s.state(), SessionState::kSolving);
  EXPECT_TRUE(s.NeedsSolve()) << "a refused start leaves the pending solve alone";
}

TEST(SessionMachineTest, StartRefusedForATimeLimitOutOfRange) {
  SessionMachine m(TestConfig());
  StartRequest r = Request();
  r.max_duration_us = -1;
  EXPECT_FALSE(m.Start(r, kT0).accepted);
  r.max_duration_us = kMaxSessionDurationUs + 1;
  const RequestReply reply = m.Start(r, kT0);
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason, "time limit must be in [0, 3600000] ms, 0 for the configured one (got " +
                              std::to_string((kMaxSessionDurationUs + 1) / 1000) + " ms)");
  EXPECT_EQ(m.state(), SessionState::kIdle);
  EXPECT_EQ(m.session(), 0);
  r.max_duration_us = kMaxSessionDurationUs;
  EXPECT_TRUE(m.Start(r, kT0).accepted);
}

// The agent may start a session long before the sensors send (test_agent_live: the publisher
// starts 2 s after the agent). The no-pair timeout counts from when both sensors send, not from
// the session's start: the first pair 1.5 s after they start is in time; 2.1 s without a pair
// after that is no_pairs.
TEST(SessionMachineTest, NoPairTimeoutCountsFromWhenBothSensorsSend) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  const int64_t t = kT0 + 5 * kS;  // nothing for 5 s
  m.FrameArrived(SensorStream::kCamera, t);
  m.FrameArrived(SensorStream::kLidar, t + 50000);
  m.Tick(t + 100000);
  EXPECT_EQ(m.state(), SessionState::kCollecting) << m.reason();
  for (int64_t dt = 100000; dt <= 1500000; dt += 100000) {
    m.FrameArrived(SensorStream::kCamera, t + dt);
    m.FrameArrived(SensorStream::kLidar, t + dt);
    m.Tick(t + dt);
  }
  EXPECT_EQ(m.state(), SessionState::kCollecting) << m.reason();
  ASSERT_TRUE(m.FrameRecorded(Figures(1, 3), t + 1500000));
  for (int64_t dt = 1600000; dt <= 3700000; dt += 100000) {
    m.FrameArrived(SensorStream::kCamera, t + dt);
    m.FrameArrived(SensorStream::kLidar, t + dt);
    m.Tick(t + dt);
  }
  EXPECT_EQ(m.state(), SessionState::kFailed);
  EXPECT_EQ(m.reason(), Reason::kNoPairs);
}

TEST(SessionMachineTest, TargetFramesEndCollectionAndRaiseNeedsSolveOnce) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(99, 150, 0b0001, 0b1), kT0 + kS));
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_FALSE(m.NeedsSolve());
  EXPECT_TRUE(m.FrameRecorded(Figures(100, 151, 0b0001, 0b1), kT0 + 2 * kS));
  EXPECT_EQ(m.state(), SessionState::kSolving);
  EXPECT_EQ(m.collection_end(), CollectionEnd::kTargetFrames);
  EXPECT_TRUE(m.NeedsSolve());
  EXPECT_FALSE(m.NeedsSolve()) << "an edge: reported once";
  EXPECT_FALSE(m.FrameRecorded(Figures(101, 152), kT0 + 3 * kS)) << "collection is over";
  EXPECT_EQ(m.figures().frames_with_boards, 100);
  EXPECT_DOUBLE_EQ(m.progress(), 0.9);
}

TEST(SessionMachineTest, CoverageGatesEndCollectionOnceMinFramesAreRecorded) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  // Gates met, but 10 of 20 frame pairs: keep collecting.
  EXPECT_TRUE(m.FrameRecorded(Figures(10, 30, kThreeBins, kFourCells), kT0 + kS));
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_EQ(m.guidance(), "coverage complete: keep collecting (10 of 20 frame pairs)");
  // Enough frames, too few boards.
  EXPECT_TRUE(m.FrameRecorded(Figures(20, 29, kThreeBins, kFourCells), kT0 + 2 * kS));
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_EQ(m.guidance(), "coverage complete: keep collecting (29 of 30 boards)");
  // Enough frames, a distance bin short.
  EXPECT_TRUE(m.FrameRecorded(Figures(21, 40, 0b0011, kFourCells), kT0 + 3 * kS));
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_TRUE(m.FrameRecorded(Figures(22, 42, kThreeBins, kFourCells), kT0 + 4 * kS));
  EXPECT_EQ(m.state(), SessionState::kSolving);
  EXPECT_EQ(m.collection_end(), CollectionEnd::kCoverage);
  EXPECT_TRUE(m.NeedsSolve());
}

TEST(SessionMachineTest, WithoutStopOnCoverageCollectionRunsToTheTarget) {
  SessionConfig config = TestConfig();
  config.stop_on_coverage = false;
  SessionMachine m(config);
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(50, 100, 0b1111, 0xffff), kT0 + kS));
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_EQ(m.guidance(), "coverage complete: collecting up to 100 frame pairs");
  EXPECT_TRUE(m.FrameRecorded(Figures(100, 200, 0b1111, 0xffff), kT0 + 2 * kS));
  EXPECT_EQ(m.collection_end(), CollectionEnd::kTargetFrames);
}

TEST(SessionMachineTest, TimeLimitSolvesWithEnoughFrames) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(25, 40, 0b0001, 0b1), kT0 + 10 * kS));
  m.Tick(kT0 + 60 * kS - 1);
  EXPECT_EQ(m.state(), SessionState::kCollecting);
  m.Tick(kT0 + 60 * kS);
  EXPECT_EQ(m.state(), SessionState::kSolving);
  EXPECT_EQ(m.collection_end(), CollectionEnd::kTimeLimit);
  EXPECT_TRUE(m.NeedsSolve());
  EXPECT_DOUBLE_EQ(m.progress(), 0.9);
}

TEST(SessionMachineTest, TimeLimitWithTooFewFramesOrBoardsFails) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(5, 15, 0b0001, 0b1), kT0 + 10 * kS));
  m.Tick(kT0 + 61 * kS);
  EXPECT_EQ(m.state(), SessionState::kFailed);
  EXPECT_EQ(m.reason(), Reason::kTooFewFrames);
  EXPECT_EQ(m.detail(), "time limit (60 s) reached with 5 frame pairs with boards, 20 needed");
  EXPECT_EQ(m.collection_end(), CollectionEnd::kTimeLimit);
  EXPECT_FALSE(m.NeedsSolve());
  EXPECT_TRUE(m.guidance().empty());

  SessionMachine b(TestConfig());
  StartRequest r = Request();
  r.max_duration_us = 1500 * 1000;  // the request's own limit, 1.5 s
  ASSERT_TRUE(b.Start(r, kT0).accepted);
  // A frame arriving after the limit ends the collection as a Tick would.
  EXPECT_TRUE(b.FrameRecorded(Figures(25, 29, 0b0001, 0b1), kT0 + 2 * kS));
  EXPECT_EQ(b.state(), SessionState::kFailed);
  EXPECT_EQ(b.reason(), Reason::kTooFewBoards);
  EXPECT_EQ(b.detail(), "time limit (1500 ms) reached with 29 board observations, 30 needed");
}

TEST(SessionMachineTest, EndOfDataEndsTheCollectionLikeTheTimeLimit) {
  SessionMachine m(TestConfig());
  m.EndOfData(kT0);  // ignored while idle
  EXPECT_EQ(m.state(), SessionState::kIdle);
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(25, 40, 0b0001, 0b1), kT0 + 2 * kS));
  m.EndOfData(kT0 + 3 * kS);
  EXPECT_EQ(m.state(), SessionState::kSolving);
  EXPECT_EQ(m.collection_end(), CollectionEnd::kEndOfData);
  EXPECT_STREQ(CollectionEndName(m.collection_end()), "end_of_data");
  EXPECT_TRUE(m.NeedsSolve());

  SessionMachine short_log(TestConfig());
  ASSERT_TRUE(short_log.Start(Request(), kT0).accepted);
  EXPECT_TRUE(short_log.FrameRecorded(Figures(5, 15, 0b0001, 0b1), kT0 + kS));
  short_log.EndOfData(kT0 + 2 * kS);
  EXPECT_EQ(short_log.state(), SessionState::kFailed);
  EXPECT_EQ(short_log.reason(), Reason::kTooFewFrames);
  EXPECT_EQ(short_log.detail(), "input ended with 5 frame pairs with boards, 20 needed");
}

TEST(SessionMachineTest, StopAbortsCollecting) {
  SessionMachine m(TestConfig());
  EXPECT_FALSE(m.Stop(kT0).accepted) << "nothing to stop";
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  EXPECT_TRUE(m.FrameRecorded(Figures(7, 9, 0b1, 0b1), kT0 + kS));
  const RequestReply reply = m.Stop(kT0 + 2 * kS);
  EXPECT_TRUE(reply.accepted);
  EXPECT_EQ(m.state(), SessionState::kAborted);
  EXPECT_EQ(m.collection_end(), CollectionEnd::kStopped);
  EXPECT_EQ(m.reason(), Reason::kStopped);
  EXPECT_EQ(m.detail(), "stopped by request while collecting (7 frame pairs with boards)");
  EXPECT_FALSE(m.NeedsSolve());
  EXPECT_TRUE(m.guidance().empty());
  const RequestReply again = m.Stop(kT0 + 3 * kS);
  EXPECT_FALSE(again.accepted);
  EXPECT_EQ(again.reason, "no session in progress (aborted)");
}

TEST(SessionMachineTest, StopDuringSolvingDiscardsTheSolve) {
  SessionMachine m = Solving();
  const int session = m.session();
  EXPECT_TRUE(m.Stop(kT0 + 2 * kS).accepted);
  EXPECT_EQ(m.state(), SessionState::kAborted);
  EXPECT_EQ(m.detail(), "stopped by request while solving (100 frame pairs with boards)");
  EXPECT_EQ(m.collection_end(), CollectionEnd::kTargetFrames) << "collection itself was complete";
  EXPECT_FALSE(m.NeedsSolve()) << "the pending solve is withdrawn";
  EXPECT_FALSE(
      m.SolveFinished(session, CalibrationOutcome::Verdict::kUpdated, Reason::kNone, "late"));
  EXPECT_FALSE(m.SolveFailed(session, Reason::kSolverFailed, "late"));
  EXPECT_EQ(m.state(), SessionState::kAborted);
  EXPECT_EQ(m.reason(), Reason::kStopped);
}

TEST(SessionMachineTest, SolveFinishedEndsInDoneWithTheVerdict) {
  for (const auto verdict :
       {CalibrationOutcome::Verdict::kVerified, CalibrationOutcome::Verdict::kUpdated,
        CalibrationOutcome::Verdict::kRejected}) {
    SessionMachine m = Solving();
    ASSERT_TRUE(m.NeedsSolve());
    const bool rejected = verdict == CalibrationOutcome::Verdict::kRejected;
    EXPECT_TRUE(m.SolveFinished(m.session(), verdict,
                                rejected ? Reason::kPoorObservability : Reason::kNone, "figures"));
    EXPECT_EQ(m.state(), SessionState::kDone);
    EXPECT_EQ(m.verdict(), verdict);
    EXPECT_EQ(m.reason(), rejected ? Reason::kPoorObservability : Reason::kNone);
    EXPECT_EQ(m.detail(), "figures");
    EXPECT_EQ(m.progress(), 1.0);
    EXPECT_FALSE(m.committed());
    EXPECT_EQ(m.guidance(), verdict == CalibrationOutcome::Verdict::kUpdated
                                ? "new calibration ready: send COMMIT to store it"
                                : "");
    EXPECT_FALSE(m.SolveFinished(m.session(), verdict, Reason::kNone, "twice")) << "only once";
  }
}

TEST(SessionMachineTest, SolveFailedEndsInFailed) {
  SessionMachine m = Solving();
  EXPECT_FALSE(m.SolveFailed(m.session() + 1, Reason::kSolverFailed, "not this session"));
  EXPECT_TRUE(m.SolveFailed(m.session(), Reason::kSolverFailed, "std::bad_alloc"));
  EXPECT_EQ(m.state(), SessionState::kFailed);
  EXPECT_EQ(m.reason(), Reason::kSolverFailed);
  EXPECT_EQ(m.detail(), "std::bad_alloc");
  EXPECT_DOUBLE_EQ(m.progress(), 0.9) << "failed keeps the progress reached";
}

TEST(SessionMachineTest, CommitOnlyAnUpdatedResultOnce) {
  SessionMachine m(TestConfig());
  RequestReply reply = m.CommitRequested();
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason, "no finished session to commit (idle)");
  m = Solving();
  EXPECT_FALSE(m.CommitRequested().accepted) << "still solving";
  ASSERT_TRUE(
      m.SolveFinished(m.session(), CalibrationOutcome::Verdict::kUpdated, Reason::kNone, ""));
  EXPECT_TRUE(m.CommitRequested().accepted);
  EXPECT_TRUE(m.committed());
  EXPECT_TRUE(m.guidance().empty());
  reply = m.CommitRequested();
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason, "already committed");

  // The store write failed: the result may be committed again.
  m.CommitFailed("cannot write '/var/lib/calibd/current.json': No space left on device");
  EXPECT_FALSE(m.committed());
  EXPECT_EQ(m.reason(), Reason::kCommitFailed);
  EXPECT_EQ(m.guidance(), "new calibration ready: send COMMIT to store it");
  EXPECT_TRUE(m.CommitRequested().accepted);
  EXPECT_EQ(m.reason(), Reason::kNone) << "a retried commit no longer reports the failed one";
}

TEST(SessionMachineTest, CommitRefusedForOtherVerdictsAndVerifyOnlySessions) {
  SessionMachine verified = Solving();
  ASSERT_TRUE(verified.SolveFinished(verified.session(), CalibrationOutcome::Verdict::kVerified,
                                     Reason::kNone, ""));
  RequestReply reply = verified.CommitRequested();
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason,
            "nothing to commit: the verdict was verified (the stored calibration "
            "stands)");

  SessionMachine rejected = Solving();
  ASSERT_TRUE(rejected.SolveFinished(rejected.session(), CalibrationOutcome::Verdict::kRejected,
                                     Reason::kHighResidual, ""));
  reply = rejected.CommitRequested();
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason, "nothing to commit: the verdict was rejected (high_residual)");

  SessionMachine verify(TestConfig());
  StartRequest r = Request();
  r.verify_only = true;
  ASSERT_TRUE(verify.Start(r, kT0).accepted);
  ASSERT_TRUE(verify.FrameRecorded(Figures(100, 300), kT0 + kS));
  ASSERT_TRUE(verify.SolveFinished(verify.session(), CalibrationOutcome::Verdict::kUpdated,
                                   Reason::kNone, ""));
  EXPECT_TRUE(verify.guidance().empty());
  reply = verify.CommitRequested();
  EXPECT_FALSE(reply.accepted);
  EXPECT_EQ(reply.reason, "verify-only session: its result is not committed");
}

TEST(SessionMachineTest, ANewStartAfterAnEndBeginsAFreshSession) {
  // From kDone (uncommitted update), kFailed and kAborted.
  SessionMachine done = Solving();
  ASSERT_TRUE(done.SolveFinished(1, CalibrationOutcome::Verdict::kUpdated, Reason::kNone, "d"));
  SessionMachine failed = Solving();
  ASSERT_TRUE(failed.SolveFailed(1, Reason::kSolverFailed, "d"));
  SessionMachine aborted = Solving();
  ASSERT_TRUE(aborted.Stop(kT0 + 2 * kS).accepted);
  for (SessionMachine* m : {&done, &failed, &aborted}) {
    StartRequest r = Request("second");
    ASSERT_TRUE(m->Start(r, kT0 + 100 * kS).accepted) << SessionStateName(m->state());
    EXPECT_EQ(m->state(), SessionState::kCollecting);
    EXPECT_EQ(m->session(), 2);
    EXPECT_EQ(m->progress(), 0.0);
    EXPECT_EQ(m->figures().frames_with_boards, 0);
    EXPECT_EQ(m->collection_end(), CollectionEnd::kNone);
    EXPECT_EQ(m->reason(), Reason::kNone);
    EXPECT_TRUE(m->detail().empty());
    EXPECT_FALSE(m->committed());
    EXPECT_FALSE(m->NeedsSolve());
    EXPECT_EQ(m->started_us(), kT0 + 100 * kS);
    EXPECT_EQ(m->request().requester, "second");
    m->Tick(kT0 + 159 * kS);
    EXPECT_EQ(m->state(), SessionState::kCollecting) << "the time limit counts from the new start";
  }
}

TEST(SessionMachineTest, AResultOfAnEarlierSessionIsIgnored) {
  SessionMachine m = Solving();
  ASSERT_TRUE(m.NeedsSolve());  // the caller starts solving session 1
  ASSERT_TRUE(m.Stop(kT0 + 2 * kS).accepted);
  ASSERT_TRUE(m.Start(Request(), kT0 + 3 * kS).accepted);
  ASSERT_TRUE(m.FrameRecorded(Figures(100, 300), kT0 + 4 * kS));
  ASSERT_EQ(m.state(), SessionState::kSolving);
  EXPECT_EQ(m.session(), 2);
  // Session 1's solve comes back late.
  EXPECT_FALSE(m.SolveFinished(1, CalibrationOutcome::Verdict::kUpdated, Reason::kNone, "stale"));
  EXPECT_EQ(m.state(), SessionState::kSolving);
  EXPECT_TRUE(m.SolveFinished(2, CalibrationOutcome::Verdict::kVerified, Reason::kNone, "fresh"));
  EXPECT_EQ(m.detail(), "fresh");
}

TEST(SessionMachineTest, GuidanceNamesMissingDistanceBinsAndImageRegions) {
  SessionConfig config = TestConfig();
  SessionMachine m(config);
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  // Boards only close, only in the top-left cell.
  EXPECT_TRUE(m.FrameRecorded(Figures(3, 5, 0b0001, 0b1), kT0 + kS));
  EXPECT_EQ(m.guidance(),
            "drive so that boards are seen at 8.5-15 m, 15-25 m, 25+ m (1 of 4 distance bins, 3 "
            "needed); boards needed in the image's top-right, bottom-left, bottom-right (1 of 16 "
            "image cells, 4 needed)");
  // Three bins; cells in the top-left and bottom-right quadrants.
  EXPECT_TRUE(m.FrameRecorded(Figures(6, 10, 0b1101, (1u << 0) | (1u << 15)), kT0 + 2 * kS));
  EXPECT_EQ(m.guidance(),
            "boards needed in the image's top-right, bottom-left (2 of 16 image cells, 4 needed)");

  // Every quadrant holds a board but too few cells: spread them.
  config.gates.min_image_cells = 6;
  SessionMachine s(config);
  StartRequest r = Request();
  r.mode = SessionMode::kStatic;
  ASSERT_TRUE(s.Start(r, kT0).accepted);
  EXPECT_TRUE(s.FrameRecorded(
      Figures(3, 5, 0b1000, (1u << 0) | (1u << 3) | (1u << 12) | (1u << 15)), kT0 + kS));
  EXPECT_EQ(s.guidance(),
            "move boards to 0-8.5 m, 8.5-15 m, 15-25 m (1 of 4 distance bins, 3 needed); spread "
            "the boards across the image (4 of 16 image cells, 6 needed)");
}

TEST(SessionMachineTest, ProgressNeverDecreasesAndStaysInRange) {
  std::mt19937 rng(7);
  for (int trial = 0; trial < 50; ++trial) {
    SessionMachine m(TestConfig());
    ASSERT_TRUE(m.Start(Request(), kT0).accepted);
    double last = m.progress();
    int64_t now = kT0;
    int frames = 0;
    while (m.state() == SessionState::kCollecting) {
      // Time mostly advances, sometimes steps back; figures mostly grow, sometimes shrink.
      now += std::uniform_int_distribution<int64_t>(-kS / 10, kS)(rng);
      frames = std::max(0, frames + std::uniform_int_distribution<int>(-1, 3)(rng));
      if (rng() % 2) {
        m.FrameRecorded(Figures(frames, 2 * frames, 0b0001, 0b1), now);
      } else {
        m.Tick(now);
      }
      EXPECT_GE(m.progress(), last);
      EXPECT_LE(m.progress(), 0.9);
      last = m.progress();
    }
    EXPECT_TRUE(m.state() == SessionState::kSolving || m.state() == SessionState::kFailed)
        << SessionStateName(m.state());
    EXPECT_GE(m.progress(), last);
    if (m.state() == SessionState::kSolving) {
      EXPECT_DOUBLE_EQ(m.progress(), 0.9);
      ASSERT_TRUE(
          m.SolveFinished(m.session(), CalibrationOutcome::Verdict::kVerified, Reason::kNone, ""));
      EXPECT_EQ(m.progress(), 1.0);
    }
  }
}

TEST(SessionMachineTest, ProgressFollowsFramesAndTime) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(m.Start(Request(), kT0).accepted);
  m.Tick(kT0 + 15 * kS);  // a quarter of the time
  EXPECT_NEAR(m.progress(), 0.9 * 0.25, 1e-12);
  EXPECT_TRUE(m.FrameRecorded(Figures(50, 60), kT0 + 16 * kS));  // half the frames
  EXPECT_NEAR(m.progress(), 0.9 * 0.5, 1e-12);
}

TEST(SessionMachineTest, NoAllocationWhileCollecting) {
  SessionMachine m(TestConfig());
  ASSERT_TRUE(
      m.Start(Request("a requester name longer than the small-string buffer"), kT0).accepted);
  const long before = calibd::testing::Allocations();
  for (int i = 0; i < 19; ++i) {
    // Guidance changes with every frame: bins and cells fill up, the frame count grows.
    m.FrameRecorded(Figures(i, 2 * i, (1u << (i % 4)) - 1, (1u << (i % 17)) - 1),
                    kT0 + i * kS / 10);
    m.Tick(kT0 + i * kS / 10 + 1);
    (void)m.guidance();
    (void)m.progress();
  }
  const long after = calibd::testing::Allocations();
  ASSERT_EQ(m.state(), SessionState::kCollecting);
  EXPECT_EQ(after - before, 0);
}

TEST(SessionMachineTest, DistanceBinsAndImageCells) {
  EXPECT_EQ(DistanceBin(0.0), 0);
  EXPECT_EQ(DistanceBin(8.49), 0);
  EXPECT_EQ(DistanceBin(8.5), 1);
  EXPECT_EQ(DistanceBin(14.99), 1);
  EXPECT_EQ(DistanceBin(15.0), 2);
  EXPECT_EQ(DistanceBin(25.0), 3);
  EXPECT_EQ(DistanceBin(300.0), 3);
  EXPECT_EQ(DistanceBin(-1.0), -1);
  EXPECT_EQ(DistanceBin(std::numeric_limits<double>::quiet_NaN()), -1);

  EXPECT_EQ(ImageCell(0.0, 0.0, 3840, 1920), 0);
  EXPECT_EQ(ImageCell(960.0, 0.0, 3840, 1920), 1);
  EXPECT_EQ(ImageCell(0.0, 480.0, 3840, 1920), 4);
  EXPECT_EQ(ImageCell(3839.9, 1919.9, 3840, 1920), 15);
  EXPECT_EQ(ImageCell(-0.1, 0.0, 3840, 1920), -1);
  EXPECT_EQ(ImageCell(3840.0, 0.0, 3840, 1920), -1);
  EXPECT_EQ(ImageCell(0.0, 1920.0, 3840, 1920), -1);
}

TEST(SessionMachineTest, ConfigFromTheAgentConfig) {
  AgentConfig agent;
  agent.target_frames = 150;
  agent.min_frames = 40;
  agent.max_duration_s = 90.5;
  agent.min_distance_bins = 2;
  agent.min_image_cells = 5;
  agent.stop_on_coverage = false;
  agent.engine.verdict.min_boards = 33;
  const SessionConfig c = SessionConfigFrom(agent);
  EXPECT_EQ(c.gates.target_frames, 150);
  EXPECT_EQ(c.gates.min_frames, 40);
  EXPECT_EQ(c.gates.min_boards, 33);
  EXPECT_EQ(c.max_duration_us, 90500000);
  EXPECT_EQ(c.gates.min_distance_bins, 2);
  EXPECT_EQ(c.gates.min_image_cells, 5);
  EXPECT_FALSE(c.stop_on_coverage);
}

TEST(SessionMachineTest, NamesOfStatesAndEnds) {
  EXPECT_STREQ(SessionStateName(SessionState::kIdle), "idle");
  EXPECT_STREQ(SessionStateName(SessionState::kCollecting), "collecting");
  EXPECT_STREQ(SessionStateName(SessionState::kSolving), "solving");
  EXPECT_STREQ(SessionStateName(SessionState::kDone), "done");
  EXPECT_STREQ(SessionStateName(SessionState::kFailed), "failed");
  EXPECT_STREQ(SessionStateName(SessionState::kAborted), "aborted");
  EXPECT_STREQ(CollectionEndName(CollectionEnd::kCoverage), "coverage");
  EXPECT_STREQ(CollectionEndName(CollectionEnd::kTimeLimit), "time_limit");
}

}  // namespace
}  // namespace calibd
