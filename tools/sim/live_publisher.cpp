#include "live_publisher.hpp"

#include <algorithm>
#include <chrono>
#include <lcm/lcm-cpp.hpp>
#include <ostream>
#include <thread>
#include <vector>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/drivers/lcm_bus.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "calibd/sensor_info_t.hpp"

namespace calibd::sim {

namespace {

struct LogSpan {
  int64_t first = 0;                          ///< the first event's time, us
  int64_t camera_first = 0, camera_last = 0;  ///< the first and last camera frame's
  int64_t camera_frames = 0;
};

// The times that set the length of one loop.
bool ReadSpan(const std::string& path, LogSpan* span, std::string* error) {
  lcm::LogFile log(path, "r");
  if (!log.good()) {
    if (error) *error = "cannot open the LCM log '" + path + "'";
    return false;
  }
  bool any = false, camera = false;
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (!any) span->first = ev->timestamp;
    any = true;
    if (ev->channel != channels::kCamera.name) continue;
    if (!camera) span->camera_first = ev->timestamp;
    span->camera_last = ev->timestamp;
    ++span->camera_frames;
    camera = true;
  }
  if (!camera && error)
    *error = "the LCM log '" + path + "' holds no camera frame (" +
             std::string(channels::kCamera.name) + ")";
  return camera;
}

// Re-encodes `msg` with its capture time moved by `shift_us` into `buffer`.
template <typename Msg>
bool Shifted(const lcm::LogEvent& ev, int64_t shift_us, Msg* msg, std::vector<uint8_t>* buffer) {
  const int size = static_cast<int>(ev.datalen);
  if (msg->decode(ev.data, 0, size) != size) return false;
  msg->utime += shift_us;
  buffer->resize(static_cast<size_t>(msg->getEncodedSize()));
  return msg->encode(buffer->data(), 0, static_cast<int>(buffer->size())) ==
         static_cast<int>(buffer->size());
}

}  // namespace

bool PublishLive(const LivePublishOptions& options, LivePublishSummary* summary,
                 std::ostream* progress, std::string* error) {
  LivePublishSummary s;
  if (options.speed <= 0.0 || options.loops < 1) {
    if (error) *error = "speed must be > 0 and loops >= 1";
    return false;
  }
  LogSpan span;
  if (!ReadSpan(options.log_path, &span, error)) return false;
  const int64_t first = span.first;
  // One loop lasts the camera frames' span plus one frame period (their mean spacing), so the
  // streams keep their spacing across the seam.
  const int64_t period_us = span.camera_frames > 1
                                ? (span.camera_last - span.camera_first) / (span.camera_frames - 1)
                                : static_cast<int64_t>(1e6 / channels::kCamera.rate_hz);
  const int64_t loop_us = span.camera_last - span.camera_first + period_us;

  LcmBus bus;
  if (!bus.Open(options.url, error)) return false;
  std::this_thread::sleep_for(std::chrono::duration<double>(options.start_delay_s));

  camera_frame_t camera;
  lidar_frame_t lidar;
  sensor_info_t info;
  std::vector<uint8_t> buffer;
  const SteadyClock::time_point start = SteadyClock::now();
  for (int loop = 0; loop < options.loops; ++loop) {
    lcm::LogFile log(options.log_path, "r");
    if (!log.good()) {
      if (error) *error = "cannot reopen the LCM log '" + options.log_path + "'";
      return false;
    }
    const int64_t shift = loop * loop_us;
    while (const lcm::LogEvent* ev = log.readNextEvent()) {
      const double at_s = static_cast<double>(ev->timestamp - first + shift) * 1e-6 / options.speed;
      const SteadyClock::time_point due = start + std::chrono::duration_cast<SteadyClock::duration>(
                                                      std::chrono::duration<double>(at_s));
      std::this_thread::sleep_until(due);
      const double late_ms = MsSince(due);
      s.max_lateness_ms = std::max(s.max_lateness_ms, late_ms);
      if (late_ms > 1e3 / channels::kCamera.rate_hz) ++s.late;

      const void* data = ev->data;
      size_t size = static_cast<size_t>(ev->datalen);
      bool ok = true;
      if (shift != 0) {
        if (ev->channel == channels::kCamera.name)
          ok = Shifted(*ev, shift, &camera, &buffer);
        else if (ev->channel == channels::kLidar.name)
          ok = Shifted(*ev, shift, &lidar, &buffer);
        else if (ev->channel == channels::kSensorInfo.name)
          ok = Shifted(*ev, shift, &info, &buffer);
        else
          buffer.assign(static_cast<const uint8_t*>(ev->data),
                        static_cast<const uint8_t*>(ev->data) + ev->datalen);
        data = buffer.data();
        size = buffer.size();
      }
      if (!ok) {
        if (error) *error = "event on " + ev->channel + " does not decode as its registry type";
        return false;
      }
      if (!bus.PublishRaw(ev->channel, data, size, error)) return false;
      s.bytes += static_cast<int64_t>(size);
      const bool camera_frame = ev->channel == channels::kCamera.name;
      const bool lidar_frame = ev->channel == channels::kLidar.name;
      s.camera += camera_frame ? 1 : 0;
      s.lidar += lidar_frame ? 1 : 0;
      s.other += camera_frame || lidar_frame ? 0 : 1;
      if (camera_frame || lidar_frame)
        s.last_frame_wall_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                   std::chrono::system_clock::now().time_since_epoch())
                                   .count();
    }
    if (progress)
      *progress << "calibd-sim: loop " << loop + 1 << "/" << options.loops << " published ("
                << s.camera << " camera, " << s.lidar << " LiDAR frames so far)\n";
  }
  s.duration_s = std::chrono::duration<double>(SteadyClock::now() - start).count();
  if (summary) *summary = s;
  return true;
}

}  // namespace calibd::sim
