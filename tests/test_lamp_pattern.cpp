// LampPattern (the status lamp's patterns) and ButtonDebouncer (the start button's debounce):
// pure logic of drivers/gpio_lines.hpp, exact levels over time. The real lines are tested in the
// VM (tests/vm/gpio_vmtest.cpp).

#include <gtest/gtest.h>

#include <cstdint>
#include <vector>

#include "calibd/drivers/gpio_lines.hpp"

namespace calibd {
namespace {

constexpr int64_t kMs = 1000;

/// Level changes of `pattern` sampled every `step_us` over [t0, t0 + duration_us).
int CountTransitions(const LampPattern& pattern, int64_t t0, int64_t duration_us, int64_t step_us) {
  int transitions = 0;
  bool last = pattern.Level(t0);
  for (int64_t t = t0; t < t0 + duration_us; t += step_us) {
    const bool level = pattern.Level(t);
    transitions += level != last ? 1 : 0;
    last = level;
  }
  return transitions;
}

TEST(LampPatternTest, IdleIsOffAndSteady) {
  LampPattern lamp;
  EXPECT_EQ(lamp.state(), LampState::kIdle);
  for (int64_t t = 0; t < 5000 * kMs; t += 10 * kMs) ASSERT_FALSE(lamp.Level(t)) << t;
  EXPECT_FALSE(lamp.NextChangeUs(0).has_value());
}

TEST(LampPatternTest, SuccessIsSteadyOn) {
  LampPattern lamp;
  lamp.Set(LampState::kSuccess, 1000 * kMs);
  for (int64_t t = 1000 * kMs; t < 6000 * kMs; t += 10 * kMs) ASSERT_TRUE(lamp.Level(t)) << t;
  EXPECT_FALSE(lamp.NextChangeUs(2000 * kMs).has_value());
}

TEST(LampPatternTest, RunningBlinksAt1HzStartingOn) {
  LampPattern lamp;
  const int64_t t0 = 7777 * kMs;
  lamp.Set(LampState::kRunning, t0);
  EXPECT_TRUE(lamp.Level(t0));
  EXPECT_TRUE(lamp.Level(t0 + 499 * kMs));
  EXPECT_FALSE(lamp.Level(t0 + 500 * kMs));
  EXPECT_FALSE(lamp.Level(t0 + 999 * kMs));
  EXPECT_TRUE(lamp.Level(t0 + 1000 * kMs));
  EXPECT_FALSE(lamp.Level(t0 + 1500 * kMs));
  // 10 s: 10 periods, 20 level changes.
  EXPECT_EQ(CountTransitions(lamp, t0, 10000 * kMs, 1 * kMs), 19);  // the 20th is at t0 + 10 s
  EXPECT_EQ(lamp.NextChangeUs(t0), t0 + 500 * kMs);
  EXPECT_EQ(lamp.NextChangeUs(t0 + 499 * kMs), t0 + 500 * kMs);
  EXPECT_EQ(lamp.NextChangeUs(t0 + 500 * kMs), t0 + 1000 * kMs);
}

TEST(LampPatternTest, FailureBlinksAt4Hz) {
  LampPattern lamp;
  const int64_t t0 = 3 * kMs;
  lamp.Set(LampState::kFailure, t0);
  const std::vector<std::pair<int64_t, bool>> expected = {{0, true},    {124, true}, {125, false},
                                                          {249, false}, {250, true}, {374, true},
                                                          {375, false}, {500, true}};
  for (const auto& [ms, level] : expected) EXPECT_EQ(lamp.Level(t0 + ms * kMs), level) << ms;
  // 1 s: 4 periods, 8 level changes (the 8th at t0 + 1 s).
  EXPECT_EQ(CountTransitions(lamp, t0, 1000 * kMs, 1 * kMs), 7);
  EXPECT_EQ(CountTransitions(lamp, t0, 1001 * kMs, 1 * kMs), 8);
  EXPECT_EQ(lamp.NextChangeUs(t0 + 130 * kMs), t0 + 250 * kMs);
}

TEST(LampPatternTest, SettingTheSameStateKeepsThePhaseAnotherRestartsOn) {
  LampPattern lamp;
  lamp.Set(LampState::kRunning, 0);
  lamp.Set(LampState::kRunning, 600 * kMs);  // same state: phase from 0 kept
  EXPECT_FALSE(lamp.Level(600 * kMs));
  lamp.Set(LampState::kFailure, 600 * kMs);  // new state: on at once
  EXPECT_TRUE(lamp.Level(600 * kMs));
  EXPECT_FALSE(lamp.Level(725 * kMs));
  lamp.Set(LampState::kIdle, 800 * kMs);
  EXPECT_FALSE(lamp.Level(800 * kMs));
  EXPECT_FALSE(lamp.Level(100000 * kMs));
}

TEST(LampPatternTest, TimeBeforeSetCountsAsSetTime) {
  LampPattern lamp;
  lamp.Set(LampState::kRunning, 1000 * kMs);
  EXPECT_TRUE(lamp.Level(0));
  EXPECT_EQ(lamp.NextChangeUs(0), 1500 * kMs);
}

TEST(LampPatternTest, StateNames) {
  EXPECT_STREQ(LampStateName(LampState::kIdle), "idle");
  EXPECT_STREQ(LampStateName(LampState::kRunning), "running");
  EXPECT_STREQ(LampStateName(LampState::kSuccess), "success");
  EXPECT_STREQ(LampStateName(LampState::kFailure), "failure");
}

// --- debounce ---

TEST(ButtonDebouncerTest, CleanPressCountsOnceAfterTheDebounceTime) {
  ButtonDebouncer d(30 * kMs);
  d.Edge(100 * kMs, true);
  EXPECT_TRUE(d.pending());
  EXPECT_EQ(d.debounce_deadline_us(), 130 * kMs);
  EXPECT_FALSE(d.Update(110 * kMs));
  EXPECT_FALSE(d.Update(129 * kMs));
  EXPECT_TRUE(d.Update(130 * kMs));
  EXPECT_FALSE(d.Update(131 * kMs));  // once
  EXPECT_FALSE(d.Update(500 * kMs));
  EXPECT_TRUE(d.stable_level());
  d.Edge(600 * kMs, false);  // release: never a press
  EXPECT_FALSE(d.Update(700 * kMs));
  EXPECT_FALSE(d.stable_level());
  EXPECT_FALSE(d.pending());
  d.Edge(800 * kMs, true);  // a second press
  EXPECT_TRUE(d.Update(900 * kMs));
}

TEST(ButtonDebouncerTest, GlitchShorterThanTheDebounceGivesNoPress) {
  ButtonDebouncer d(30 * kMs);
  d.Edge(100 * kMs, true);
  d.Edge(105 * kMs, false);
  EXPECT_FALSE(d.pending());
  for (int64_t t = 100 * kMs; t < 1000 * kMs; t += kMs) ASSERT_FALSE(d.Update(t)) << t;
}

TEST(ButtonDebouncerTest, BouncingPressGivesOnePressAfterTheLastBounce) {
  ButtonDebouncer d(30 * kMs);
  // Contact bounce: on, off, on, off, on within 8 ms, then held.
  const int64_t edges_ms[] = {100, 102, 104, 106, 108};
  bool level = true;
  for (int64_t ms : edges_ms) {
    d.Edge(ms * kMs, level);
    EXPECT_FALSE(d.Update(ms * kMs));
    level = !level;
  }
  EXPECT_FALSE(d.Update(137 * kMs));  // 30 ms after the first edge, but not after the last
  int presses = 0;
  for (int64_t t = 109 * kMs; t < 500 * kMs; t += kMs) presses += d.Update(t) ? 1 : 0;
  EXPECT_EQ(presses, 1);
  // Release with bounce: no press.
  d.Edge(600 * kMs, false);
  d.Edge(601 * kMs, true);
  d.Edge(603 * kMs, false);
  for (int64_t t = 603 * kMs; t < 900 * kMs; t += kMs) ASSERT_FALSE(d.Update(t));
  EXPECT_FALSE(d.stable_level());
}

TEST(ButtonDebouncerTest, RepeatedLevelRestartsTheDebounce) {
  // The kernel reads the level when it handles the interrupt: a fast bounce may show as two
  // rising edges. The second one still restarts the time.
  ButtonDebouncer d(30 * kMs);
  d.Edge(100 * kMs, true);
  d.Edge(120 * kMs, true);
  EXPECT_FALSE(d.Update(140 * kMs));
  EXPECT_TRUE(d.Update(150 * kMs));
}

TEST(ButtonDebouncerTest, HeldAtStartGivesNoPressUntilReleasedAndPressedAgain) {
  ButtonDebouncer d(30 * kMs, /*initial_level=*/true);
  EXPECT_FALSE(d.Update(1000 * kMs));
  d.Edge(1100 * kMs, false);
  EXPECT_FALSE(d.Update(1200 * kMs));
  d.Edge(1300 * kMs, true);
  EXPECT_TRUE(d.Update(1330 * kMs));
}

TEST(ButtonDebouncerTest, ZeroDebounceCountsAtTheEdge) {
  ButtonDebouncer d(0);
  d.Edge(100 * kMs, true);
  EXPECT_TRUE(d.Update(100 * kMs));
}

TEST(ButtonDebouncerTest, EdgeStampedAfterNowWaits) {
  // An event stamped after the caller read its clock: not yet debounced.
  ButtonDebouncer d(30 * kMs);
  d.Edge(100 * kMs, true);
  EXPECT_FALSE(d.Update(90 * kMs));
  EXPECT_TRUE(d.Update(130 * kMs));
}

TEST(GpioLogicalLevelTest, ActiveLowInverts) {
  EXPECT_TRUE(GpioLogicalLevel(true, false));
  EXPECT_FALSE(GpioLogicalLevel(false, false));
  EXPECT_FALSE(GpioLogicalLevel(true, true));
  EXPECT_TRUE(GpioLogicalLevel(false, true));
}

}  // namespace
}  // namespace calibd
