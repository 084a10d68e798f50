#pragma once
/// \file
/// Publishes a recorded (or simulated) session on a live LCM transport in real time, the way the
/// sensor drivers would: each event at its recorded time after the start (scaled by `speed`),
/// optionally looped with every capture time shifted by the log's length so that the stream
/// keeps going forward in time (a 200-frame log played 10 times is a 2000-frame session).

#include <cstdint>
#include <iosfwd>
#include <string>

namespace calibd::sim {

struct LivePublishOptions {
  std::string log_path;        ///< LCM log to play (calibd-sim --out)
  std::string url;             ///< LCM URL to publish on, e.g. udpm://239.255.76.67:7667?ttl=0
  double speed = 1.0;          ///< 1 = real time; 2 = twice as fast
  int loops = 1;               ///< times the log is played
  double start_delay_s = 0.0;  ///< wait before the first event (subscribers joining)
};

struct LivePublishSummary {
  int64_t camera = 0, lidar = 0, other = 0;  ///< events published
  int64_t bytes = 0;
  double duration_s = 0.0;
  /// Events published more than one frame period (100 ms) behind their schedule: the publisher
  /// itself could not keep the rate (disk or CPU), not the receiver.
  int64_t late = 0;
  double max_lateness_ms = 0.0;
  /// Wall-clock time (CLOCK_REALTIME, us) right after the last camera or LiDAR frame went out:
  /// the start of the agent's "last frame to result" latency.
  int64_t last_frame_wall_us = 0;
};

/// Plays the log; false with `error` when the log or the URL cannot be opened, an event of a
/// frame channel does not decode, or publishing fails. Progress lines go to `progress` (may be
/// null), one per loop.
bool PublishLive(const LivePublishOptions& options, LivePublishSummary* summary,
                 std::ostream* progress, std::string* error);

}  // namespace calibd::sim
