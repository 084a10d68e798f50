// The agent's streaming intake on real simulated messages: pairs detected on the worker threads
// match a direct detection of the same frames, a full queue drops the newest pair and keeps the
// queued ones, the LiDAR detector's capacities are counted, and bad, foreign, out-of-order and
// inactive-time messages are counted and skipped.

#include "calibd/agent/frame_intake.hpp"

#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/lidar_reference_file.hpp"
#include "simulated_messages.hpp"
#include "small_camera.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

using Messages = testing::SimulatedMessages;

// 6 frame pairs of the default drive, every 5th frame, as the sensors send them: the small
// camera and the m1 LiDAR, which the simulator renders in a fraction of the default's time (each
// test is a process of its own under ctest, and this runs under the sanitizers too).
const Messages& SimulatedMessages() {
  static const Messages m = [] {
    sim::SessionOptions options;
    options.lidar_model = "m1";
    options.camera = testing::SmallCamera();
    return testing::SimulateMessages(options, 6, 5);
  }();
  return m;
}

// A queue of `queue` pairs; the LiDAR references from one sampling of each view, a quarter of the
// default's start-up build (it dominates these tests, the more so under the sanitizers): the
// boards of these frames are found all the same.
IntakeConfig SmallIntake(int queue) {
  IntakeConfig c;
  c.queue_capacity = queue;
  c.lidar.reference_samples = 1;
  return c;
}

// Drains until `pairs` pairs came out or 20 s passed.
int DrainAll(FrameIntake* intake, SessionObservations* session, int pairs) {
  int got = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (got < pairs && std::chrono::steady_clock::now() < deadline) {
    got += intake->Drain(session);
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  }
  return got;
}

TEST(FrameIntakeTest, DetectsPairsLikeTheDetectorsDirectly) {
  const Messages& m = SimulatedMessages();
  FrameIntake intake;
  std::string error;
  ASSERT_TRUE(intake.Init(SmallIntake(8), m.config, &error)) << error;
  ASSERT_TRUE(intake.AwaitStartup()) << intake.startup().error;
  intake.SetActive(true);
  for (size_t k = 0; k < m.camera.size(); ++k) {
    intake.OnCamera(m.camera[k]);
    intake.OnLidar(m.lidar[k]);
  }
  SessionObservations session;
  session.Reserve(20, 8, 4096);
  EXPECT_EQ(DrainAll(&intake, &session, 6), 6);
  EXPECT_TRUE(intake.Idle());
  EXPECT_EQ(intake.counters().pairs_detected, 6);
  EXPECT_EQ(intake.counters().bad_messages, 0) << intake.counters().last_error;

  // The same frames through the detectors directly, in one thread.
  const IntakeConfig same = SmallIntake(8);
  CameraDetector camera(same.camera, m.config.camera, m.config.boards);
  LidarKind kind;
  ASSERT_TRUE(LidarKindFromName(m.config.lidar_model, &kind, &error));
  LidarDetector lidar(same.lidar, MakeLidarModel(kind), m.config.boards);
  SessionObservations direct;
  direct.Reserve(20, 8, 4096);
  cv::Mat decoded;
  for (size_t k = 0; k < m.camera.size(); ++k) {
    ImageView view;
    PointCloudView cloud;
    ASSERT_TRUE(CameraFrameToView(m.camera[k], FrameLimits{}, &decoded, &view, &error));
    ASSERT_TRUE(LidarFrameToView(m.lidar[k], FrameLimits{}, &cloud, &error));
    CameraDetections cd;
    LidarDetections ld;
    camera.Detect(view, &cd, m.camera[k].utime);  // tracks the stream as the intake does
    lidar.Detect(cloud, &ld);
    direct.AddFrame(cd, ld, m.config.boards, FrameTimes{m.camera[k].utime, m.lidar[k].utime});
  }
  ASSERT_EQ(session.num_frames, direct.num_frames);
  ASSERT_EQ(session.camera.size(), direct.camera.size());
  ASSERT_EQ(session.lidar.size(), direct.lidar.size());
  EXPECT_EQ(session.camera.size(), 18u);  // 3 boards in each of 6 frames
  for (size_t i = 0; i < session.camera.size(); ++i) {
    EXPECT_EQ(session.camera[i].frame, direct.camera[i].frame);
    EXPECT_EQ(session.camera[i].board_index, direct.camera[i].board_index);
    EXPECT_TRUE(session.camera[i].T_camera_board.isApprox(direct.camera[i].T_camera_board, 1e-9));
  }
  EXPECT_EQ(session.points, direct.points);
  EXPECT_EQ(session.frame_times[3].camera_utime, m.camera[3].utime);
}

// The LiDAR references kept between starts (IntakeConfig::reference_cache_file): the first
// start builds them and writes the file, creating its directory; the next takes them from it
// and detects the same boards in the same frames; a damaged file is named, rebuilt and rewritten.
TEST(FrameIntakeTest, TheLidarReferencesAreKeptBetweenStartsAndADamagedCacheIsRebuilt) {
  const Messages& m = SimulatedMessages();
  const testing::TempDir dir;
  IntakeConfig config = SmallIntake(8);
  config.reference_cache_file = dir.file("cache/lidar-references.bin");
  auto start = [&](SessionObservations* session) {
    FrameIntake intake;
    std::string error;
    EXPECT_TRUE(intake.Init(config, m.config, &error)) << error;
    EXPECT_TRUE(intake.AwaitStartup()) << intake.startup().error;
    intake.SetActive(true);
    for (size_t k = 0; k < 3; ++k) {
      intake.OnCamera(m.camera[k]);
      intake.OnLidar(m.lidar[k]);
    }
    session->Reserve(20, 8, 4096);
    EXPECT_EQ(DrainAll(&intake, session, 3), 3);
    return intake.startup();
  };
  SessionObservations first, second, third;
  const FrameIntake::Startup built = start(&first);
  EXPECT_FALSE(built.from_cache);
  EXPECT_EQ(built.cache_note, "written to '" + config.reference_cache_file + "'");
  LidarReferenceSet kept;
  std::string error;
  ASSERT_TRUE(ReadReferenceFile(config.reference_cache_file, &kept, &error)) << error;
  EXPECT_EQ(static_cast<int>(kept.views.size()), built.references);

  const FrameIntake::Startup cached = start(&second);
  EXPECT_TRUE(cached.from_cache);
  EXPECT_EQ(cached.cache_note, "");
  EXPECT_EQ(cached.references, built.references);
  EXPECT_FALSE(first.lidar.empty());
  EXPECT_EQ(second.lidar.size(), first.lidar.size());
  EXPECT_EQ(second.points, first.points);

  // One byte flipped in the middle of the descriptors: the CRC-32 tells.
  std::string bytes;
  ASSERT_TRUE(ReadWholeFile(config.reference_cache_file, &bytes, &error)) << error;
  bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x10);
  ASSERT_TRUE(WriteFileAtomic(config.reference_cache_file, bytes, &error)) << error;
  const FrameIntake::Startup rebuilt = start(&third);
  EXPECT_FALSE(rebuilt.from_cache);
  EXPECT_EQ(rebuilt.cache_note, "'" + config.reference_cache_file +
                                    "': CRC-32 mismatch (a damaged file); written to '" +
                                    config.reference_cache_file + "'");
  EXPECT_EQ(third.points, first.points);
  ASSERT_TRUE(ReadReferenceFile(config.reference_cache_file, &kept, &error)) << error;
}

// The LiDAR detector's fixed capacities: what does not fit is counted per pair drained.
TEST(FrameIntakeTest, LidarDetectorCapacitiesAreCounted) {
  const Messages& m = SimulatedMessages();
  IntakeConfig config = SmallIntake(8);
  config.lidar.max_boards = 1;
  config.lidar.max_board_points = 8;
  FrameIntake intake;
  std::string error;
  ASSERT_TRUE(intake.Init(config, m.config, &error)) << error;
  ASSERT_TRUE(intake.AwaitStartup()) << intake.startup().error;
  intake.SetActive(true);
  for (size_t k = 0; k < m.camera.size(); ++k) {
    intake.OnCamera(m.camera[k]);
    intake.OnLidar(m.lidar[k]);
  }
  SessionObservations session;
  session.Reserve(20, 8, 4096);
  ASSERT_EQ(DrainAll(&intake, &session, 6), 6);
  const IntakeCounters& c = intake.counters();
  EXPECT_GT(c.lidar_boards_dropped, 0);     // 3 boards in view, 1 kept per pair
  EXPECT_EQ(c.lidar_boards_subsampled, 6);  // each kept board has more than 8 points
  EXPECT_EQ(session.lidar.size(), 6u);
  for (const auto& cluster : session.lidar) EXPECT_EQ(cluster.num_points, 8);
  EXPECT_EQ(c.lidar_candidates_dropped + c.lidar_points_overflow, 0);
}

TEST(FrameIntakeTest, FullQueueDropsTheNewestPairAndKeepsTheQueuedOnes) {
  const Messages& m = SimulatedMessages();
  FrameIntake intake;
  std::string error;
  ASSERT_TRUE(intake.Init(SmallIntake(2), m.config, &error)) << error;
  ASSERT_TRUE(intake.AwaitStartup()) << intake.startup().error;
  intake.SetActive(true);
  // Six pairs at once, nothing drained: 2 queued + 1 filling slot hold 3 pairs; once the slots
  // are all taken the newer pairs are dropped (how many depends on how fast the workers are, but
  // never the queued ones, and every pair is either drained or counted as dropped).
  for (size_t k = 0; k < m.camera.size(); ++k) {
    intake.OnCamera(m.camera[k]);
    intake.OnLidar(m.lidar[k]);
  }
  const auto& c = intake.counters();
  EXPECT_GE(c.dropped_queue_full, 3);
  SessionObservations session;
  session.Reserve(20, 8, 4096);
  const int drained = DrainAll(&intake, &session, 6 - static_cast<int>(c.dropped_queue_full));
  EXPECT_EQ(drained + c.dropped_queue_full, 6);
  // Per sensor: each dropped camera frame took its sweep with it; no sweep went unpaired.
  EXPECT_EQ(c.lidar_dropped_queue_full, c.dropped_queue_full);
  EXPECT_EQ(c.unpaired_lidar, 0);
  EXPECT_EQ(c.unpaired_camera, 0);
  EXPECT_EQ(session.frame_times[0].camera_utime, m.camera[0].utime);  // the oldest were kept
  EXPECT_EQ(session.frame_times[1].camera_utime, m.camera[1].utime);
  EXPECT_TRUE(intake.Idle());
}

TEST(FrameIntakeTest, FramesMissingFromAStreamAreCountedPerSensor) {
  const Messages& m = SimulatedMessages();
  FrameIntake intake;
  std::string error;
  ASSERT_TRUE(intake.Init(SmallIntake(2), m.config, &error)) << error;
  ASSERT_TRUE(intake.AwaitStartup()) << intake.startup().error;
  // Counted while not collecting too (health reports them all the time). Camera frame 4 never
  // arrives (lost in the network); every sweep does.
  for (size_t k = 0; k < m.camera.size(); ++k) {
    if (k != 4) intake.OnCamera(m.camera[k]);
    intake.OnLidar(m.lidar[k]);
  }
  EXPECT_EQ(intake.counters().camera_missed, 1);
  EXPECT_EQ(intake.counters().lidar_missed, 0);
  EXPECT_EQ(intake.counters().camera_frames, 5);
}

TEST(FrameIntakeTest, BadForeignOutOfOrderAndInactiveMessagesAreCountedAndSkipped) {
  const Messages& m = SimulatedMessages();
  FrameIntake intake;
  std::string error;
  ASSERT_TRUE(intake.Init(SmallIntake(4), m.config, &error)) << error;
  ASSERT_TRUE(intake.AwaitStartup()) << intake.startup().error;
  // Not collecting: counted only.
  intake.OnCamera(m.camera[0]);
  intake.OnLidar(m.lidar[0]);
  EXPECT_EQ(intake.counters().ignored_inactive, 2);
  intake.SetActive(true);

  camera_frame_t other = m.camera[0];
  other.camera_id = "rear";  // another camera's frames are not ours
  intake.OnCamera(other);
  EXPECT_EQ(intake.counters().camera_frames, 1);

  // A frame whose header lies about its size: detected as malformed in the worker, skipped.
  camera_frame_t lying = m.camera[1];
  lying.size = 7;
  intake.OnCamera(lying);
  intake.OnLidar(m.lidar[1]);
  // A duplicate of an earlier sweep: out of order.
  intake.OnLidar(m.lidar[0]);
  // A sweep with more points than the limits: refused before it is copied.
  lidar_frame_t huge = m.lidar[2];
  huge.num_points = 500000;
  intake.OnCamera(m.camera[2]);
  intake.OnLidar(huge);
  // A good pair still goes through.
  intake.OnCamera(m.camera[3]);
  intake.OnLidar(m.lidar[3]);

  SessionObservations session;
  session.Reserve(20, 8, 4096);
  DrainAll(&intake, &session, 1);
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!intake.Idle() && std::chrono::steady_clock::now() < deadline) intake.Drain(&session);
  const auto& c = intake.counters();
  EXPECT_EQ(c.bad_messages, 2) << c.last_error;
  EXPECT_EQ(c.out_of_order, 1);
  EXPECT_EQ(c.unpaired_camera, 1);  // camera[2] lost its sweep
  EXPECT_EQ(c.pairs_detected, 1);
  ASSERT_EQ(session.num_frames, 1);
  EXPECT_EQ(session.frame_times[0].camera_utime, m.camera[3].utime);
}

}  // namespace
}  // namespace calibd
