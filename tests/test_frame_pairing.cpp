// FramePairer: the pairing window and its edges, displaced camera frames, sweeps without a camera
// frame, out-of-order and duplicated times, and the counters.

#include "calibd/core/session/frame_pairing.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdint>
#include <limits>
#include <optional>
#include <random>
#include <string>

namespace calibd {
namespace {

// 10 Hz LiDAR, 20 ms tolerance: a sweep starting at t pairs with a camera time in
// [t - 20000, t + 120000].
FramePairingConfig TenHz() {
  FramePairingConfig c;
  c.pair_tolerance_us = 20000;
  c.sweep_us = 100000;
  return c;
}

constexpr int64_t kT0 = 1700000000000000;  // a realistic epoch time, us

TEST(FramePairingConfigTest, DefaultsAreValidAndBadValuesNameTheKey) {
  std::string error;
  EXPECT_TRUE(FramePairingConfig{}.IsValid(&error)) << error;
  FramePairingConfig c;
  c.pair_tolerance_us = -1;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("pair_tolerance_us"), std::string::npos) << error;
  EXPECT_NE(error.find("-1"), std::string::npos) << error;
  c = FramePairingConfig{};
  c.pair_tolerance_us = 1000001;
  EXPECT_FALSE(c.IsValid(&error));
  c = FramePairingConfig{};
  c.sweep_us = 0;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_NE(error.find("sweep_us"), std::string::npos) << error;
  c.sweep_us = 1000000;
  c.pair_tolerance_us = 0;
  EXPECT_TRUE(c.IsValid(nullptr));  // null error is allowed
}

TEST(FramePairerTest, CameraInsideTheSweepPairs) {
  FramePairer pairer(TenHz());
  const FramePairer::CameraResult c = pairer.OnCamera(kT0 + 50000);
  EXPECT_TRUE(c.accepted);
  EXPECT_FALSE(c.displaced);
  EXPECT_TRUE(pairer.has_pending());
  EXPECT_EQ(pairer.pending_utime(), kT0 + 50000);
  const FramePairer::LidarResult l = pairer.OnLidar(kT0);
  EXPECT_TRUE(l.accepted);
  EXPECT_TRUE(l.paired);
  EXPECT_EQ(l.camera_utime, kT0 + 50000);
  EXPECT_FALSE(pairer.has_pending());
  EXPECT_FALSE(pairer.Flush());
  const FramePairingCounters& n = pairer.counters();
  EXPECT_EQ(n.camera_frames, 1);
  EXPECT_EQ(n.lidar_frames, 1);
  EXPECT_EQ(n.pairs, 1);
  EXPECT_EQ(n.unpaired_camera, 0);
  EXPECT_EQ(n.unpaired_lidar, 0);
}

TEST(FramePairerTest, ToleranceEdgesAreIncluded) {
  struct Case {
    int64_t camera_offset_us;  // camera time minus sweep start
    bool pairs;
  };
  const Case cases[] = {
      {-20000, true}, {-20001, false},  // before the sweep: tolerance
      {0, true},      {100000, true},   // the sweep itself
      {120000, true}, {120001, false},  // after the sweep: duration + tolerance
  };
  for (const Case& k : cases) {
    FramePairer pairer(TenHz());
    pairer.OnCamera(kT0 + k.camera_offset_us);
    const FramePairer::LidarResult l = pairer.OnLidar(kT0);
    EXPECT_TRUE(l.accepted);
    EXPECT_EQ(l.paired, k.pairs) << "camera at sweep start + " << k.camera_offset_us << " us";
    EXPECT_EQ(pairer.counters().unpaired_lidar, k.pairs ? 0 : 1);
    EXPECT_EQ(pairer.has_pending(), !k.pairs);  // an unpaired sweep leaves the frame waiting
  }
  // Zero tolerance: exactly the sweep.
  FramePairingConfig exact = TenHz();
  exact.pair_tolerance_us = 0;
  FramePairer pairer(exact);
  pairer.OnCamera(kT0 - 1);
  EXPECT_FALSE(pairer.OnLidar(kT0).paired);
  pairer.OnCamera(kT0 + 100000);
  EXPECT_TRUE(pairer.OnLidar(kT0 + 1).paired);
}

TEST(FramePairerTest, NewerCameraFrameDisplacesThePendingOne) {
  FramePairer pairer(TenHz());
  pairer.OnCamera(kT0);
  const FramePairer::CameraResult c = pairer.OnCamera(kT0 + 100000);
  EXPECT_TRUE(c.accepted);
  EXPECT_TRUE(c.displaced);
  EXPECT_EQ(c.displaced_utime, kT0);
  EXPECT_EQ(pairer.counters().unpaired_camera, 1);
  // The newer frame is the one that pairs.
  const FramePairer::LidarResult l = pairer.OnLidar(kT0 + 90000);
  EXPECT_TRUE(l.paired);
  EXPECT_EQ(l.camera_utime, kT0 + 100000);
  EXPECT_EQ(pairer.counters().pairs, 1);
}

TEST(FramePairerTest, SweepWithoutCameraFrameIsUnpaired) {
  FramePairer pairer(TenHz());
  FramePairer::LidarResult l = pairer.OnLidar(kT0);
  EXPECT_TRUE(l.accepted);
  EXPECT_FALSE(l.paired);
  EXPECT_EQ(pairer.counters().unpaired_lidar, 1);
  // A camera frame later than the next sweep's window: that sweep is unpaired too, and the frame
  // waits for the sweep after it.
  pairer.OnCamera(kT0 + 250000);
  l = pairer.OnLidar(kT0 + 100000);
  EXPECT_TRUE(l.accepted);
  EXPECT_FALSE(l.paired);
  EXPECT_TRUE(pairer.has_pending());
  l = pairer.OnLidar(kT0 + 200000);
  EXPECT_TRUE(l.paired);
  EXPECT_EQ(l.camera_utime, kT0 + 250000);
  EXPECT_EQ(pairer.counters().unpaired_lidar, 2);
  EXPECT_EQ(pairer.counters().unpaired_camera, 0);
  EXPECT_EQ(pairer.counters().pairs, 1);
}

TEST(FramePairerTest, CameraFrameTooOldForEverySweepEndsUnpaired) {
  FramePairer pairer(TenHz());
  pairer.OnCamera(kT0);
  EXPECT_FALSE(pairer.OnLidar(kT0 + 200000).paired);
  EXPECT_FALSE(pairer.OnLidar(kT0 + 300000).paired);
  EXPECT_TRUE(pairer.has_pending());
  EXPECT_TRUE(pairer.Flush());  // end of stream
  EXPECT_FALSE(pairer.has_pending());
  EXPECT_EQ(pairer.counters().unpaired_camera, 1);
  EXPECT_EQ(pairer.counters().unpaired_lidar, 2);
}

TEST(FramePairerTest, OutOfOrderAndDuplicateTimesAreDroppedAndCounted) {
  FramePairer pairer(TenHz());
  EXPECT_TRUE(pairer.OnCamera(kT0 + 50000).accepted);
  // A duplicate and an earlier camera time: dropped, the pending frame untouched.
  FramePairer::CameraResult c = pairer.OnCamera(kT0 + 50000);
  EXPECT_FALSE(c.accepted);
  EXPECT_FALSE(c.displaced);
  c = pairer.OnCamera(kT0 + 10000);
  EXPECT_FALSE(c.accepted);
  EXPECT_EQ(pairer.pending_utime(), kT0 + 50000);
  EXPECT_EQ(pairer.counters().out_of_order_camera, 2);
  EXPECT_EQ(pairer.counters().unpaired_camera, 0);

  EXPECT_TRUE(pairer.OnLidar(kT0).paired);
  // The same sweep again (e.g. a retransmission) and an earlier one: dropped, not unpaired.
  pairer.OnCamera(kT0 + 150000);
  FramePairer::LidarResult l = pairer.OnLidar(kT0);
  EXPECT_FALSE(l.accepted);
  EXPECT_FALSE(l.paired);
  l = pairer.OnLidar(kT0 - 100000);
  EXPECT_FALSE(l.accepted);
  EXPECT_EQ(pairer.counters().out_of_order_lidar, 2);
  EXPECT_EQ(pairer.counters().unpaired_lidar, 0);
  EXPECT_TRUE(pairer.has_pending());  // still waiting for its own sweep
  EXPECT_TRUE(pairer.OnLidar(kT0 + 100000).paired);

  const FramePairingCounters& n = pairer.counters();
  EXPECT_EQ(n.camera_frames, 4);
  EXPECT_EQ(n.lidar_frames, 4);
  EXPECT_EQ(n.pairs, 2);
}

TEST(FramePairerTest, DropPendingDoesNotCountAndResetStartsAfresh) {
  FramePairer pairer(TenHz());
  pairer.OnCamera(kT0);
  EXPECT_TRUE(pairer.DropPending());
  EXPECT_FALSE(pairer.DropPending());
  EXPECT_EQ(pairer.counters().unpaired_camera, 0);
  EXPECT_FALSE(pairer.OnLidar(kT0).paired);  // nothing pending any more
  // Order is still checked after DropPending.
  EXPECT_FALSE(pairer.OnCamera(kT0).accepted);

  pairer.Reset();
  EXPECT_EQ(pairer.counters().camera_frames, 0);
  EXPECT_EQ(pairer.counters().unpaired_lidar, 0);
  EXPECT_EQ(pairer.config().sweep_us, 100000);
  // After a reset, earlier times are accepted again (e.g. a new session after a clock step).
  EXPECT_TRUE(pairer.OnCamera(kT0 - 1000000).accepted);
  EXPECT_TRUE(pairer.OnLidar(kT0 - 1000000).paired);
}

TEST(FramePairerTest, ExtremeTimesDoNotOverflow) {
  FramePairer pairer(TenHz());
  const int64_t max = std::numeric_limits<int64_t>::max();
  const int64_t min = std::numeric_limits<int64_t>::min();
  pairer.OnCamera(max);
  EXPECT_TRUE(pairer.OnLidar(max - 50000).paired);
  FramePairer other(TenHz());
  other.OnCamera(min + 10);
  EXPECT_TRUE(other.OnLidar(min + 15000).paired);  // camera 14990 us before: within tolerance
  EXPECT_FALSE(other.OnLidar(max).paired);
}

// A steady 10 Hz stream with the camera mid-sweep: every frame pairs, nothing is left over.
TEST(FramePairerTest, SteadyStreamPairsEveryFrame) {
  FramePairer pairer(TenHz());
  for (int i = 0; i < 100; ++i) {
    const int64_t sweep = kT0 + i * 100000;
    EXPECT_TRUE(pairer.OnCamera(sweep + 50000 + (i % 7) * 1000).accepted);
    EXPECT_TRUE(pairer.OnLidar(sweep).paired) << i;
  }
  EXPECT_FALSE(pairer.Flush());
  EXPECT_EQ(pairer.counters().pairs, 100);
  EXPECT_EQ(pairer.counters().unpaired_camera + pairer.counters().unpaired_lidar, 0);
}

// Oracle: the pairing that calibd-calibrate did inline before FramePairer existed. On streams in
// each sensor's time order the pairer must count exactly the same.
struct InlineReference {
  FramePairingConfig config;
  std::optional<int64_t> pending;
  int64_t pairs = 0, unpaired_camera = 0, unpaired_lidar = 0;

  void OnCamera(int64_t t) {
    if (pending) ++unpaired_camera;
    pending = t;
  }
  void OnLidar(int64_t t) {
    if (!pending || *pending < t - config.pair_tolerance_us ||
        *pending > t + config.sweep_us + config.pair_tolerance_us) {
      ++unpaired_lidar;
      return;
    }
    ++pairs;
    pending.reset();
  }
  void Flush() {
    if (pending) ++unpaired_camera;
  }
};

TEST(FramePairerTest, MatchesTheCliInlineLogicOnRandomStreams) {
  std::mt19937 rng(7);
  std::uniform_int_distribution<int> lag_us(-60000, 160000);  // camera vs sweep start
  std::uniform_int_distribution<int> step_us(1, 60000);
  std::bernoulli_distribution drop(0.2), camera_first(0.7);
  int64_t total_pairs = 0, total_unpaired_camera = 0, total_unpaired_lidar = 0;
  for (int run = 0; run < 200; ++run) {
    FramePairingConfig config = TenHz();
    config.pair_tolerance_us = run % 3 == 0 ? 0 : 20000;
    FramePairer pairer(config);
    InlineReference reference{config, std::nullopt};
    int64_t last_camera = kT0 - 1000000, last_lidar = kT0 - 1000000;
    for (int i = 0; i < 50; ++i) {
      const int64_t sweep = kT0 + i * 100000;
      // Camera time near the sweep but strictly after the previous camera frame.
      const int64_t camera = std::max(sweep + lag_us(rng), last_camera + step_us(rng));
      const bool send_camera = !drop(rng), send_lidar = !drop(rng);
      const bool first = camera_first(rng);
      for (int k = 0; k < 2; ++k) {
        if ((k == 0) == first && send_camera) {
          pairer.OnCamera(camera);
          reference.OnCamera(camera);
          last_camera = camera;
        } else if ((k == 0) != first && send_lidar && sweep > last_lidar) {
          pairer.OnLidar(sweep);
          reference.OnLidar(sweep);
          last_lidar = sweep;
        }
      }
    }
    pairer.Flush();
    reference.Flush();
    const FramePairingCounters& n = pairer.counters();
    ASSERT_EQ(n.pairs, reference.pairs) << "run " << run;
    ASSERT_EQ(n.unpaired_camera, reference.unpaired_camera) << "run " << run;
    ASSERT_EQ(n.unpaired_lidar, reference.unpaired_lidar) << "run " << run;
    ASSERT_EQ(n.out_of_order_camera + n.out_of_order_lidar, 0) << "run " << run;
    total_pairs += n.pairs;
    total_unpaired_camera += n.unpaired_camera;
    total_unpaired_lidar += n.unpaired_lidar;
  }
  // The streams exercise every outcome, not only pairs.
  EXPECT_GT(total_pairs, 1000);
  EXPECT_GT(total_unpaired_camera, 500);
  EXPECT_GT(total_unpaired_lidar, 500);
}

}  // namespace
}  // namespace calibd
