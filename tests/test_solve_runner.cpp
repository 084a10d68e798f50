// The agent's solve thread (agent/solve_runner.hpp): the outcome is the poll loop's only once
// collected, a finished solve stays pending until then (a start request in between must not take
// it away), and a new session forgets it.

#include "calibd/agent/solve_runner.hpp"

#include <gtest/gtest.h>
#include <poll.h>

#include <string>

#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {
namespace {

TEST(SolveRunnerTest, AFinishedSolveWaitsForCollectAndANewSessionForgetsIt) {
  WakeEvent wake;
  std::string error;
  ASSERT_TRUE(wake.Open(&error)) << error;
  CalibConfig calib;
  const SessionObservations empty;  // nothing seen: the engine refuses at once
  const RangeImage projection = SessionProjection(MakeLidarModel(LidarKind::kOt128));
  const EngineConfig engine;
  SolveRunner runner;
  EXPECT_FALSE(runner.pending());
  EXPECT_EQ(runner.outcome(), nullptr);
  runner.Start(3, calib, empty, projection, engine, &wake, 1234);
  EXPECT_TRUE(runner.pending());
  EXPECT_EQ(runner.session(), 3);
  EXPECT_EQ(runner.started_us(), 1234);
  pollfd p{wake.fd(), POLLIN, 0};
  ASSERT_EQ(::poll(&p, 1, 10000), 1) << "the wake event was not signalled";
  ASSERT_TRUE(runner.finished());
  EXPECT_FALSE(runner.running());
  EXPECT_EQ(runner.outcome(), nullptr) << "not the poll loop's before Collect";
  EXPECT_TRUE(runner.finished()) << "stays finished until collected";
  runner.Collect();
  EXPECT_FALSE(runner.pending());
  ASSERT_NE(runner.outcome(), nullptr);
  EXPECT_EQ(runner.outcome()->verdict, CalibrationOutcome::Verdict::kRejected);
  runner.Clear();
  EXPECT_EQ(runner.outcome(), nullptr);
  // A solve no one collected (an aborted session's) is forgotten by the next session too.
  runner.Start(4, calib, empty, projection, engine, &wake, 5678);
  runner.Clear();
  EXPECT_FALSE(runner.pending());
  EXPECT_EQ(runner.outcome(), nullptr);
}

}  // namespace
}  // namespace calibd
