// The agent's view of its sensors apart from their frames (agent/sensor_watch.hpp): liveness,
// the data-timeout test while collecting, and a replaced sensor told by its serial number. And
// the STATUS= line for systemd (agent/service_status.hpp), sent only when it changes.

#include "calibd/agent/sensor_watch.hpp"

#include <gtest/gtest.h>

#include <string>
#include <utility>
#include <vector>

#include "calibd/agent/service_status.hpp"

namespace calibd {
namespace {

constexpr int64_t kS = 1000000;

sensor_info_t Info(int8_t kind, const std::string& id, const std::string& serial) {
  sensor_info_t m;
  m.utime = 0;
  m.kind = kind;
  m.sensor_id = id;
  m.serial_number = serial;
  return m;
}

TEST(SensorWatchTest, ASensorIsAliveForOneSecondAfterItsLastFrame) {
  SensorWatch w("cam", "lidar");
  EXPECT_FALSE(w.Alive(SensorStream::kCamera, 5 * kS)) << "no frame yet";
  w.FrameArrived(SensorStream::kCamera, 5 * kS);
  EXPECT_TRUE(w.Alive(SensorStream::kCamera, 5 * kS + kSensorAliveUs));
  EXPECT_FALSE(w.Alive(SensorStream::kCamera, 5 * kS + kSensorAliveUs + 1));
  EXPECT_FALSE(w.Alive(SensorStream::kLidar, 5 * kS)) << "the other sensor";
}

// While collecting, a sensor silent for more than a second fails the test once; its next frame
// passes it again. Before the collection started its silence does not count, and outside a
// collection nothing fails.
TEST(SensorWatchTest, TimeoutsFailOnceWhileCollectingAndPassWithTheNextFrame) {
  SensorWatch w("cam", "lidar");
  std::vector<std::pair<SensorStream, bool>> reports;
  auto record = [&](SensorStream s, bool timed_out) { reports.emplace_back(s, timed_out); };
  w.FrameArrived(SensorStream::kCamera, 1 * kS);
  w.FrameArrived(SensorStream::kLidar, 1 * kS);
  w.CheckTimeouts(false, 0, 10 * kS, record);
  EXPECT_TRUE(reports.empty()) << "not collecting";
  const int64_t since = 10 * kS;
  w.CheckTimeouts(true, since, since + kSensorAliveUs, record);
  EXPECT_TRUE(reports.empty()) << "silent since the start for 1 s only";
  w.FrameArrived(SensorStream::kCamera, since + kS);
  w.CheckTimeouts(true, since, since + kS + kSensorAliveUs / 2, record);
  ASSERT_EQ(reports.size(), 1u);
  EXPECT_EQ(reports[0], std::make_pair(SensorStream::kLidar, true));
  w.CheckTimeouts(true, since, since + 3 * kS, record);
  ASSERT_EQ(reports.size(), 2u) << "the LiDAR only once; now the camera too";
  EXPECT_EQ(reports[1], std::make_pair(SensorStream::kCamera, true));
  w.FrameArrived(SensorStream::kLidar, since + 4 * kS);
  w.CheckTimeouts(true, since, since + 4 * kS, record);
  ASSERT_EQ(reports.size(), 3u);
  EXPECT_EQ(reports[2], std::make_pair(SensorStream::kLidar, false));
}

// A serial other than the stored calibration's is a replaced sensor, told once until cleared;
// other sensors, "unknown" stored serials and no stored calibration say nothing.
TEST(SensorWatchTest, AReplacedSensorIsToldOnceByItsSerial) {
  SensorWatch w("cam", "lidar");
  StoredCalibration stored;
  stored.lidar_serial = "L-1";
  stored.camera_serial = "unknown";
  std::string line;
  EXPECT_FALSE(w.OnSensorInfo(Info(sensor_info_t::KIND_LIDAR, "lidar", "L-1"), &stored, &line));
  EXPECT_EQ(w.serial(SensorStream::kLidar), "L-1");
  EXPECT_FALSE(w.OnSensorInfo(Info(sensor_info_t::KIND_LIDAR, "rear", "R-9"), &stored, &line))
      << "not a sensor in use";
  EXPECT_EQ(w.serial(SensorStream::kLidar), "L-1");
  EXPECT_FALSE(w.OnSensorInfo(Info(sensor_info_t::KIND_CAMERA, "cam", "C-7"), &stored, &line))
      << "the stored camera serial is unknown";
  EXPECT_FALSE(w.mismatch());
  EXPECT_FALSE(w.OnSensorInfo(Info(sensor_info_t::KIND_LIDAR, "lidar", "L-2"), nullptr, &line))
      << "no stored calibration";
  ASSERT_TRUE(w.OnSensorInfo(Info(sensor_info_t::KIND_LIDAR, "lidar", "L-3"), &stored, &line));
  EXPECT_EQ(line,
            "LiDAR serial L-3 differs from the stored calibration's L-1: recalibration "
            "required");
  EXPECT_TRUE(w.mismatch());
  EXPECT_FALSE(w.OnSensorInfo(Info(sensor_info_t::KIND_LIDAR, "lidar", "L-4"), &stored, &line))
      << "told once";
  w.ClearMismatch();
  EXPECT_FALSE(w.mismatch());
}

TEST(ServiceStatusTest, TheLineIsSentWhenItChangesOnly) {
  SessionConfig config;
  config.gates.target_frames = 10;
  SessionMachine machine(config);
  ServiceStatus status;
  const char* line = status.Changed(machine);
  ASSERT_NE(line, nullptr);
  EXPECT_STREQ(line, "idle");
  EXPECT_EQ(status.Changed(machine), nullptr) << "unchanged";
  StartRequest r;
  r.requester = "test";
  ASSERT_TRUE(machine.Start(r, kS).accepted);
  line = status.Changed(machine);
  ASSERT_NE(line, nullptr);
  EXPECT_STREQ(line, "session 1: collecting 0%");
  machine.Stop(2 * kS);
  line = status.Changed(machine);
  ASSERT_NE(line, nullptr);
  EXPECT_STREQ(line, "session 1: aborted (stopped)");
}

}  // namespace
}  // namespace calibd
