#include "calibd/core/session/stream_gaps.hpp"

#include <gtest/gtest.h>

namespace calibd {
namespace {

constexpr int64_t kPeriod = 100000;  // 10 Hz

TEST(StreamGapsTest, ASteadyStreamMissesNothing) {
  StreamGaps g;
  for (int i = 0; i < 50; ++i) EXPECT_EQ(g.Observe(1000000 + i * kPeriod + (i % 3) * 2000), 0);
  EXPECT_EQ(g.missed(), 0);
  EXPECT_NEAR(static_cast<double>(g.period_us()), kPeriod - 2000, 2000);
}

TEST(StreamGapsTest, CountsTheFramesMissingInAGap) {
  StreamGaps g;
  int64_t t = 5000000;
  for (int i = 0; i < 10; ++i) g.Observe(t += kPeriod);
  EXPECT_EQ(g.Observe(t += 2 * kPeriod), 1);  // one frame lost
  EXPECT_EQ(g.Observe(t += 4 * kPeriod), 3);  // three more
  EXPECT_EQ(g.Observe(t += kPeriod), 0);
  EXPECT_EQ(g.missed(), 4);
}

TEST(StreamGapsTest, JitterBelowHalfAPeriodIsNoGap) {
  StreamGaps g;
  int64_t t = 0;
  for (int i = 0; i < 10; ++i) g.Observe(t += kPeriod);
  EXPECT_EQ(g.Observe(t += kPeriod * 14 / 10), 0);
  EXPECT_EQ(g.missed(), 0);
}

TEST(StreamGapsTest, ARestartOrABackwardsTimeIsNotCountedAsLoss) {
  StreamGaps g;
  int64_t t = 1000000;
  for (int i = 0; i < 10; ++i) g.Observe(t += kPeriod);
  EXPECT_EQ(g.Observe(t += 30 * 1000000), 0);  // the sensor restarted 30 s later
  EXPECT_EQ(g.Observe(t - 5 * kPeriod), 0);    // backwards: ignored
  EXPECT_EQ(g.Observe(t), 0);                  // repeated: ignored
  // The period is learnt again before gaps count: the first intervals after a restart are free.
  EXPECT_EQ(g.Observe(t += 3 * kPeriod), 0);
  EXPECT_EQ(g.missed(), 0);
}

// Repeated and reordered times are counted apart from gaps; a clock stepped back by more
// than kRestartUs is a restart, after which gaps count again (before, every frame until the old
// time was passed again was ignored, hiding its gaps).
TEST(StreamGapsTest, DuplicatesLateFramesAndAClockStepBackAreCounted) {
  StreamGaps g;
  int64_t t = 100000000;
  for (int i = 0; i < 10; ++i) g.Observe(t += kPeriod);
  EXPECT_EQ(g.Observe(t), 0);                // duplicate
  EXPECT_EQ(g.Observe(t - 2 * kPeriod), 0);  // late
  EXPECT_EQ(g.duplicates(), 1);
  EXPECT_EQ(g.late(), 1);
  EXPECT_EQ(g.restarts(), 0);
  t -= 60 * 1000000;  // the clock steps back a minute
  EXPECT_EQ(g.Observe(t), 0);
  EXPECT_EQ(g.restarts(), 1);
  EXPECT_EQ(g.late(), 1);
  for (int i = 0; i < 5; ++i) EXPECT_EQ(g.Observe(t += kPeriod), 0);
  EXPECT_EQ(g.Observe(t += 3 * kPeriod), 2);   // gaps count on the new timeline
  EXPECT_EQ(g.Observe(t += 30 * 1000000), 0);  // a long pause: a restart too
  EXPECT_EQ(g.restarts(), 2);
  EXPECT_EQ(g.missed(), 2);
}

TEST(StreamGapsTest, TheFirstIntervalsOnlyTeachThePeriod) {
  StreamGaps g;
  int64_t t = 1000000;
  g.Observe(t);
  EXPECT_EQ(g.Observe(t += 3 * kPeriod), 0);  // cannot tell yet: is the rate 3.3 Hz?
  EXPECT_EQ(g.Observe(t += kPeriod), 0);
  EXPECT_EQ(g.Observe(t += kPeriod), 0);
  EXPECT_EQ(g.Observe(t += 2 * kPeriod), 1);
  EXPECT_EQ(g.period_us(), kPeriod);
}

}  // namespace
}  // namespace calibd
