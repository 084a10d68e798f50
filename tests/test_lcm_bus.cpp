// LcmBus on real LCM transports, no mocks: memq:// round trips and undecodable messages, file://
// replay of a log written by LcmLogWriter through the same Open/poll/Handle path as the agent,
// udpm:// on loopback (skipped when the host has no multicast route), the queue bound and its
// drop policy, and the errors for bad URLs, channels and types.

#include "calibd/drivers/lcm_bus.hpp"

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <string>
#include <thread>
#include <vector>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/drivers/lcm_log.hpp"
#include "calibd/health_t.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "calibd/sensor_info_t.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

const std::string kCameraChannel(channels::kCamera.name);
const std::string kLidarChannel(channels::kLidar.name);

camera_frame_t MakeCamera(int64_t utime, int width = 64, int height = 48) {
  camera_frame_t m;
  m.utime = utime;
  m.camera_id = "cam0";
  m.width = width;
  m.height = height;
  m.stride = width;
  m.encoding = camera_frame_t::ENCODING_MONO8;
  m.data.resize(static_cast<size_t>(width * height));
  for (size_t i = 0; i < m.data.size(); ++i) m.data[i] = static_cast<uint8_t>((i * 7 + 3) & 0xff);
  m.size = static_cast<int32_t>(m.data.size());
  return m;
}

lidar_frame_t MakeLidar(int64_t utime, int num_points = 100) {
  lidar_frame_t m;
  m.utime = utime;
  m.lidar_id = "lidar0";
  m.num_points = num_points;
  for (int i = 0; i < num_points; ++i) {
    m.x.push_back(0.01f * static_cast<float>(i));
    m.y.push_back(-0.02f * static_cast<float>(i));
    m.z.push_back(1.5f);
    m.intensity.push_back(static_cast<float>(i % 256));
    m.ring.push_back(static_cast<int16_t>(i % 128));
    m.time_offset_us.push_back(i * 10);
  }
  return m;
}

health_t MakeHealth(int64_t utime) {
  health_t m{};
  m.utime = utime;
  m.software_version = "test";
  return m;
}

void ExpectSameCamera(const camera_frame_t& a, const camera_frame_t& b) {
  EXPECT_EQ(a.utime, b.utime);
  EXPECT_EQ(a.camera_id, b.camera_id);
  EXPECT_EQ(a.width, b.width);
  EXPECT_EQ(a.height, b.height);
  EXPECT_EQ(a.stride, b.stride);
  EXPECT_EQ(a.encoding, b.encoding);
  EXPECT_EQ(a.size, b.size);
  EXPECT_EQ(a.data, b.data);
}

void ExpectSameLidar(const lidar_frame_t& a, const lidar_frame_t& b) {
  EXPECT_EQ(a.utime, b.utime);
  EXPECT_EQ(a.lidar_id, b.lidar_id);
  EXPECT_EQ(a.num_points, b.num_points);
  EXPECT_EQ(a.x, b.x);
  EXPECT_EQ(a.y, b.y);
  EXPECT_EQ(a.z, b.z);
  EXPECT_EQ(a.intensity, b.intensity);
  EXPECT_EQ(a.ring, b.ring);
  EXPECT_EQ(a.time_offset_us, b.time_offset_us);
}

// The agent's loop, reduced to the bus: poll its descriptor, then dispatch what is ready.
// Returns Handle's result, or 0 when the descriptor stayed quiet for `timeout_ms`.
int PollOnce(LcmBus& bus, int timeout_ms) {
  pollfd p{bus.fileno(), POLLIN, 0};
  if (::poll(&p, 1, timeout_ms) <= 0) return 0;
  return bus.Handle(0);
}

// Dispatches until the bus stays quiet for `quiet_ms` or fails; returns the messages dispatched.
int Drain(LcmBus& bus, int quiet_ms = 200) {
  int total = 0;
  for (int n; (n = PollOnce(bus, quiet_ms)) > 0;) total += n;
  return total;
}

struct Received {
  std::vector<camera_frame_t> cameras;
  std::vector<lidar_frame_t> lidars;
  std::vector<int64_t> recv_utimes;
  std::vector<std::string> order;  ///< "C<utime>" / "L<utime>" in delivery order
};

void SubscribeFrames(LcmBus& bus, Received* r, int capacity = 8) {
  std::string error;
  ASSERT_TRUE(bus.Subscribe<camera_frame_t>(
      kCameraChannel, capacity,
      [r](const camera_frame_t& m, int64_t recv_utime) {
        r->cameras.push_back(m);
        r->recv_utimes.push_back(recv_utime);
        r->order.push_back("C" + std::to_string(m.utime));
      },
      &error))
      << error;
  ASSERT_TRUE(bus.Subscribe<lidar_frame_t>(
      kLidarChannel, capacity,
      [r](const lidar_frame_t& m, int64_t recv_utime) {
        r->lidars.push_back(m);
        r->recv_utimes.push_back(recv_utime);
        r->order.push_back("L" + std::to_string(m.utime));
      },
      &error))
      << error;
}

// A per-process channel for udpm tests, so that concurrent test processes do not hear each other.
std::string UniqueChannel(const std::string& base) {
  return "CALIBD_TEST_" + base + "_" + std::to_string(::getpid());
}

// Loopback multicast on a port of its own (not LCM's default 7667).
const char* kUdpmUrl = "udpm://239.255.76.67:7681?ttl=0";

TEST(LcmBusTest, MemqRoundTripOfCameraAndLidarFrames) {
  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  EXPECT_TRUE(bus.is_open());
  EXPECT_EQ(bus.url(), "memq://");
  EXPECT_GE(bus.fileno(), 0);
  Received r;
  SubscribeFrames(bus, &r);

  const camera_frame_t camera = MakeCamera(1000);
  const lidar_frame_t lidar = MakeLidar(900, 500);
  ASSERT_TRUE(bus.Publish(kCameraChannel, camera, &error)) << error;
  ASSERT_TRUE(bus.Publish(kLidarChannel, lidar, &error)) << error;
  EXPECT_EQ(Drain(bus), 2);
  ASSERT_EQ(r.cameras.size(), 1u);
  ASSERT_EQ(r.lidars.size(), 1u);
  ExpectSameCamera(r.cameras[0], camera);
  ExpectSameLidar(r.lidars[0], lidar);
  EXPECT_EQ(r.order, (std::vector<std::string>{"C1000", "L900"}));
  for (int64_t t : r.recv_utimes) EXPECT_GT(t, 0);  // memq: the publish time (wall clock)
  EXPECT_EQ(bus.counters(kCameraChannel).received, 1);
  EXPECT_EQ(bus.counters(kLidarChannel).received, 1);
  EXPECT_EQ(bus.decode_errors(), 0);
  EXPECT_EQ(bus.Handle(0), 0);  // nothing left: a timeout, not an error
}

TEST(LcmBusTest, MessageThatDoesNotDecodeIsCountedAndSkipped) {
  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  Received r;
  SubscribeFrames(bus, &r);

  // A health_t on the camera channel (another type: its hash differs), a camera frame cut short,
  // and a LiDAR frame whose point count says -1 (lcm-gen's decode throws on the resize).
  const health_t health = MakeHealth(1);
  std::vector<uint8_t> bytes(static_cast<size_t>(health.getEncodedSize()));
  health.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  ASSERT_TRUE(bus.PublishRaw(kCameraChannel, bytes.data(), bytes.size(), &error)) << error;

  const camera_frame_t camera = MakeCamera(2000);
  bytes.resize(static_cast<size_t>(camera.getEncodedSize()));
  camera.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  ASSERT_TRUE(bus.PublishRaw(kCameraChannel, bytes.data(), bytes.size() - 10, &error)) << error;

  lidar_frame_t lidar = MakeLidar(1900, 0);
  lidar.lidar_id = "l";
  bytes.resize(static_cast<size_t>(lidar.getEncodedSize()));
  lidar.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  // hash (8) + utime (8) + id length (4) + "l\0" (2): num_points, big-endian int32.
  for (size_t i = 22; i < 26; ++i) bytes[i] = 0xff;
  ASSERT_TRUE(bus.PublishRaw(kLidarChannel, bytes.data(), bytes.size(), &error)) << error;

  // Then good frames: delivered as if nothing had happened.
  ASSERT_TRUE(bus.Publish(kCameraChannel, camera, &error)) << error;
  ASSERT_TRUE(bus.Publish(kLidarChannel, MakeLidar(1950), &error)) << error;
  EXPECT_EQ(Drain(bus), 5);
  ASSERT_EQ(r.cameras.size(), 1u);
  ExpectSameCamera(r.cameras[0], camera);
  ASSERT_EQ(r.lidars.size(), 1u);
  EXPECT_EQ(r.lidars[0].utime, 1950);
  EXPECT_EQ(bus.counters(kCameraChannel).received, 3);
  EXPECT_EQ(bus.counters(kCameraChannel).decode_errors, 2);
  EXPECT_EQ(bus.counters(kLidarChannel).received, 2);
  EXPECT_EQ(bus.counters(kLidarChannel).decode_errors, 1);
  EXPECT_EQ(bus.decode_errors(), 3);
  EXPECT_EQ(bus.counters("NOT_SUBSCRIBED").received, 0);
}

// Inputs found by the fuzz targets (tests/fuzz/corpus/lcm_*/crash-*): an array count far beyond
// the message's bytes (a 78-byte lidar_frame_t claiming 0x0d0d0d0d points, a camera_frame_t's
// `size` likewise). lcm-gen's decode zero-filled the array to that count before finding the bytes
// missing: seconds and ~1 GB per message, kept as the reused message's capacity. Refused now
// before decode runs.
TEST(LcmBusTest, ArrayCountsBeyondTheMessageAreRefusedBeforeDecoding) {
  const auto read = [](const std::string& name) {
    std::ifstream in(std::string(CALIBD_SOURCE_DIR) + "/tests/fuzz/corpus/" + name,
                     std::ios::binary);
    return std::vector<uint8_t>(std::istreambuf_iterator<char>(in), {});
  };
  const std::vector<uint8_t> lidar_bytes = read("lcm_lidar/crash-huge-num-points");
  const std::vector<uint8_t> camera_bytes = read("lcm_camera/crash-huge-size");
  ASSERT_EQ(lidar_bytes.size(), 78u);
  ASSERT_EQ(camera_bytes.size(), 157u);
  const int lidar_size = static_cast<int>(lidar_bytes.size());
  const int camera_size = static_cast<int>(camera_bytes.size());
  const lidar_frame_t* lidar_type = nullptr;
  const camera_frame_t* camera_type = nullptr;
  EXPECT_FALSE(lcm_bus_detail::EncodedCountsFit(lidar_type, lidar_bytes.data(), lidar_size));
  EXPECT_FALSE(lcm_bus_detail::EncodedCountsFit(camera_type, camera_bytes.data(), camera_size));
  lcm_bus_detail::TypedDecoder<lidar_frame_t> lidar([](const lidar_frame_t&, int64_t) {});
  lcm_bus_detail::TypedDecoder<camera_frame_t> camera([](const camera_frame_t&, int64_t) {});
  const auto t0 = std::chrono::steady_clock::now();
  EXPECT_FALSE(lidar.Decode(lidar_bytes.data(), lidar_size));
  EXPECT_FALSE(camera.Decode(camera_bytes.data(), camera_size));
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(100));

  // Real frames still fit exactly, and one point more than the bytes hold does not.
  const lidar_frame_t good = MakeLidar(1000);
  std::vector<uint8_t> bytes(static_cast<size_t>(good.getEncodedSize()));
  good.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  const int size = static_cast<int>(bytes.size());
  EXPECT_TRUE(lcm_bus_detail::EncodedCountsFit(lidar_type, bytes.data(), size));
  EXPECT_TRUE(lidar.Decode(bytes.data(), size));
  const size_t count_at = 8 + 8 + 4 + good.lidar_id.size() + 1;
  bytes[count_at + 3] = static_cast<uint8_t>(bytes[count_at + 3] + 1);
  EXPECT_FALSE(lcm_bus_detail::EncodedCountsFit(lidar_type, bytes.data(), size));
  // A string length of INT32_MIN (lcm-gen's decode computed length - 1 with signed overflow).
  good.encode(bytes.data(), 0, size);
  const size_t string_at = 8 + 8;  // fingerprint, utime, then lidar_id's int32 length
  bytes[string_at] = 0x80;
  bytes[string_at + 1] = bytes[string_at + 2] = bytes[string_at + 3] = 0x00;
  EXPECT_FALSE(lcm_bus_detail::EncodedCountsFit(lidar_type, bytes.data(), size));
  EXPECT_FALSE(lidar.Decode(bytes.data(), size));
  const camera_frame_t cam = MakeCamera(1000);
  bytes.resize(static_cast<size_t>(cam.getEncodedSize()));
  cam.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  EXPECT_TRUE(camera.Decode(bytes.data(), static_cast<int>(bytes.size())));
}

TEST(LcmBusTest, RegistryChannelsOnlyCarryTheirType) {
  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  EXPECT_FALSE(bus.Subscribe<health_t>(
      kCameraChannel, 4, [](const health_t&, int64_t) {}, &error));
  EXPECT_NE(error.find("calibd.camera_frame_t"), std::string::npos) << error;
  EXPECT_NE(error.find("health_t"), std::string::npos) << error;
  EXPECT_FALSE(bus.Publish(kLidarChannel, MakeHealth(1), &error));
  EXPECT_NE(error.find(kLidarChannel), std::string::npos) << error;
  // The right type on a registry channel, and any type on a channel outside the registry.
  EXPECT_TRUE(bus.Subscribe<health_t>(
      std::string(channels::kHealth.name), 4, [](const health_t&, int64_t) {}, &error))
      << error;
  EXPECT_TRUE(bus.Subscribe<health_t>(
      "CALIBD_TEST_ANY", 4, [](const health_t&, int64_t) {}, &error))
      << error;
}

TEST(LcmBusTest, BadChannelsAndCapacitiesAreRefused) {
  LcmBus bus;
  std::string error;
  auto subscribe = [&](const std::string& channel, int capacity) {
    return bus.Subscribe<health_t>(
        channel, capacity, [](const health_t&, int64_t) {}, &error);
  };
  EXPECT_FALSE(subscribe("CALIBD_TEST_H", 4));  // not open
  EXPECT_NE(error.find("not open"), std::string::npos) << error;
  EXPECT_LT(bus.Handle(0), 0);
  EXPECT_EQ(bus.fileno(), -1);

  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  EXPECT_FALSE(subscribe("CALIBD.*", 4));  // a regular expression would match other channels
  EXPECT_NE(error.find("CALIBD.*"), std::string::npos) << error;
  EXPECT_FALSE(subscribe("", 4));
  EXPECT_FALSE(subscribe(std::string(64, 'A'), 4));
  EXPECT_FALSE(subscribe("CALIBD_TEST_H", 0));
  EXPECT_NE(error.find("queue capacity"), std::string::npos) << error;
  EXPECT_TRUE(subscribe("CALIBD_TEST_H", 4)) << error;
  EXPECT_FALSE(subscribe("CALIBD_TEST_H", 4));
  EXPECT_NE(error.find("already subscribed"), std::string::npos) << error;
  const uint8_t byte = 0;
  EXPECT_FALSE(bus.PublishRaw("BAD CHANNEL", &byte, 1, &error));
}

TEST(LcmBusTest, BadUrlsGiveErrorsNamingTheUrl) {
  LcmBus bus;
  std::string error;
  EXPECT_FALSE(bus.Open("nope://x", &error));
  EXPECT_NE(error.find("nope://x"), std::string::npos) << error;
  EXPECT_NE(error.find("unknown provider 'nope'"), std::string::npos) << error;
  EXPECT_FALSE(bus.is_open());
  EXPECT_EQ(bus.fileno(), -1);

  EXPECT_FALSE(bus.Open("garbage", &error));
  EXPECT_NE(error.find("'garbage'"), std::string::npos) << error;
  EXPECT_NE(error.find("malformed"), std::string::npos) << error;

  EXPECT_FALSE(bus.Open("udpm://999.1.1.1:7667", &error));
  EXPECT_NE(error.find("udpm://999.1.1.1:7667"), std::string::npos) << error;

  EXPECT_FALSE(bus.Open("file:///nonexistent/dir/x.lcmlog?speed=0", &error));
  EXPECT_NE(error.find("/nonexistent/dir/x.lcmlog"), std::string::npos) << error;

  // A failed Open leaves a closed bus that a good URL opens.
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  EXPECT_TRUE(bus.is_open());
}

TEST(LcmBusTest, EmptyUrlUsesTheEnvironmentsDefault) {
  ASSERT_EQ(::setenv("LCM_DEFAULT_URL", "memq://", 1), 0);
  LcmBus bus;
  std::string error;
  const bool opened = bus.Open("", &error);
  ::unsetenv("LCM_DEFAULT_URL");
  ASSERT_TRUE(opened) << error;
  EXPECT_EQ(bus.url(), "memq://");
}

TEST(LcmBusTest, HandleDispatchesAtMostMaxMessages) {
  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  int received = 0;
  ASSERT_TRUE(bus.Subscribe<health_t>(
      "CALIBD_TEST_H", 100, [&](const health_t&, int64_t) { ++received; }, &error))
      << error;
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(bus.Publish("CALIBD_TEST_H", MakeHealth(i), &error));
  EXPECT_EQ(bus.Handle(100, 4), 4);
  EXPECT_EQ(bus.Handle(0, 4), 4);
  EXPECT_EQ(bus.Handle(0, 4), 2);
  EXPECT_EQ(bus.Handle(0, 4), 0);
  EXPECT_EQ(received, 10);
}

// memq admits a message when it dispatches it: the capacity never drops anything there (the
// bound acts where a receive thread queues ahead of Handle, see UdpmQueueCapacityDropsTheNewest).
TEST(LcmBusTest, MemqNeverDrops) {
  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("memq://", &error)) << error;
  std::vector<int64_t> times;
  ASSERT_TRUE(bus.Subscribe<health_t>(
      "CALIBD_TEST_H", 2, [&](const health_t& m, int64_t) { times.push_back(m.utime); }, &error))
      << error;
  for (int i = 0; i < 10; ++i) ASSERT_TRUE(bus.Publish("CALIBD_TEST_H", MakeHealth(i), &error));
  EXPECT_EQ(Drain(bus), 10);
  EXPECT_EQ(times.size(), 10u);
}

// A log written by the project's LcmLogWriter, replayed through file://PATH?speed=0 with the
// agent's Open/poll/Handle path: every event in order, the bad one counted, then end of log.
TEST(LcmBusTest, FileLogReplaysThroughTheSamePath) {
  testing::TempDir dir;
  const std::string path = dir.file("session.lcmlog");
  std::vector<camera_frame_t> cameras;
  std::vector<lidar_frame_t> lidars;
  std::vector<std::string> written;
  {
    LcmLogWriter log;
    std::string error;
    ASSERT_TRUE(log.Open(path, &error)) << error;
    sensor_info_t info{};
    info.utime = 1;
    info.sensor_id = "cam0";
    ASSERT_TRUE(log.WriteMessage(std::string(channels::kSensorInfo.name), 1, info, &error));
    for (int i = 0; i < 5; ++i) {
      const int64_t t = 1000000 + i * 100000;
      cameras.push_back(MakeCamera(t + 50000));
      lidars.push_back(MakeLidar(t, 200 + i));
      ASSERT_TRUE(log.WriteMessage(kCameraChannel, t + 50000, cameras.back(), &error)) << error;
      ASSERT_TRUE(log.WriteMessage(kLidarChannel, t + 100000, lidars.back(), &error)) << error;
      written.push_back("C" + std::to_string(t + 50000));
      written.push_back("L" + std::to_string(t));
      if (i == 2) {
        const char junk[] = "not a lidar_frame_t";
        ASSERT_TRUE(log.Write(kLidarChannel, t + 100001, junk, sizeof(junk), &error)) << error;
      }
    }
    ASSERT_TRUE(log.Close(&error)) << error;
  }

  LcmBus bus;
  std::string error;
  ASSERT_TRUE(bus.Open("file://" + path + "?speed=0", &error)) << error;
  Received r;
  SubscribeFrames(bus, &r, /*capacity=*/2);  // file:// reads as fast as Handle: nothing dropped
  // The first three events (sensor info, camera, LiDAR) in one bounded call.
  EXPECT_EQ(bus.Handle(1000, 3), 3);
  int status = 0;
  for (int i = 0; i < 100 && (status = PollOnce(bus, 1000)) > 0; ++i) {
  }
  EXPECT_LT(status, 0);
  EXPECT_TRUE(bus.end_of_log());
  EXPECT_LT(bus.Handle(0), 0);  // stays ended

  EXPECT_EQ(r.order, written);
  ASSERT_EQ(r.cameras.size(), cameras.size());
  ASSERT_EQ(r.lidars.size(), lidars.size());
  for (size_t i = 0; i < cameras.size(); ++i) ExpectSameCamera(r.cameras[i], cameras[i]);
  for (size_t i = 0; i < lidars.size(); ++i) ExpectSameLidar(r.lidars[i], lidars[i]);
  EXPECT_EQ(bus.counters(kLidarChannel).received, 6);
  EXPECT_EQ(bus.counters(kLidarChannel).decode_errors, 1);
  EXPECT_EQ(bus.counters(kCameraChannel).decode_errors, 0);
  // A log opened for reading refuses to publish.
  EXPECT_FALSE(bus.Publish(kCameraChannel, cameras[0], &error));
  EXPECT_NE(error.find("publish"), std::string::npos) << error;
}

// Opens the loopback multicast bus, or says why the test cannot run on this host.
bool OpenUdpm(LcmBus* bus, std::string* why) { return bus->Open(kUdpmUrl, why); }

TEST(LcmBusTest, UdpmRoundTripOnLoopback) {
  LcmBus bus;
  std::string error;
  if (!OpenUdpm(&bus, &error)) GTEST_SKIP() << "no loopback multicast here: " << error;
  // Unique channels: the registry's names would be heard by every process on this group.
  const std::string camera_channel = UniqueChannel("CAM"), lidar_channel = UniqueChannel("LIDAR");
  std::vector<camera_frame_t> cameras;
  std::vector<lidar_frame_t> lidars;
  ASSERT_TRUE(bus.Subscribe<camera_frame_t>(
      camera_channel, 4, [&](const camera_frame_t& m, int64_t) { cameras.push_back(m); }, &error))
      << error;
  ASSERT_TRUE(bus.Subscribe<lidar_frame_t>(
      lidar_channel, 4, [&](const lidar_frame_t& m, int64_t) { lidars.push_back(m); }, &error))
      << error;
  const camera_frame_t camera = MakeCamera(5000);
  const lidar_frame_t lidar = MakeLidar(4900, 3000);  // 66 kB: sent in several fragments
  ASSERT_TRUE(bus.Publish(camera_channel, camera, &error)) << error;
  ASSERT_TRUE(bus.Publish(lidar_channel, lidar, &error)) << error;
  EXPECT_EQ(Drain(bus, 1000), 2);
  ASSERT_EQ(cameras.size(), 1u);
  ASSERT_EQ(lidars.size(), 1u);
  ExpectSameCamera(cameras[0], camera);
  ExpectSameLidar(lidars[0], lidar);
}

// With nobody calling Handle, LCM's receive thread queues at most capacity + 1 messages (liblcm
// 1.3 compares with <=) and drops every newer one: the oldest are delivered, the newest lost.
TEST(LcmBusTest, UdpmQueueCapacityDropsTheNewest) {
  LcmBus bus;
  std::string error;
  if (!OpenUdpm(&bus, &error)) GTEST_SKIP() << "no loopback multicast here: " << error;
  const std::string channel = UniqueChannel("QUEUE");
  constexpr int kCapacity = 3;
  std::vector<int64_t> times;
  ASSERT_TRUE(bus.Subscribe<health_t>(
      channel, kCapacity, [&](const health_t& m, int64_t) { times.push_back(m.utime); }, &error))
      << error;
  for (int i = 0; i < 20; ++i) ASSERT_TRUE(bus.Publish(channel, MakeHealth(i), &error)) << error;
  // A slow consumer: the receive thread has taken every datagram before Handle runs.
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  Drain(bus);
  ASSERT_GE(times.size(), static_cast<size_t>(kCapacity));
  ASSERT_LE(times.size(), static_cast<size_t>(kCapacity + 1));
  for (size_t i = 0; i < times.size(); ++i) EXPECT_EQ(times[i], static_cast<int64_t>(i));
  EXPECT_EQ(bus.counters(channel).received, static_cast<int64_t>(times.size()));
  // The bound is on what waits, not on the total: once drained, new messages get through.
  times.clear();
  for (int i = 100; i < 102; ++i) ASSERT_TRUE(bus.Publish(channel, MakeHealth(i), &error));
  Drain(bus);
  EXPECT_EQ(times, (std::vector<int64_t>{100, 101}));
}

}  // namespace
}  // namespace calibd
