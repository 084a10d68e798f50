#pragma once
/// \file
/// Pairs camera frames with LiDAR sweeps by their capture times, shared by the offline CLI and
/// the agent. Only times go in: the caller keeps the frames and learns from each call what to do
/// with them.
///
/// The camera is triggered while the sweep crosses its view, so its capture time lies within the
/// sweep: a sweep starting at t_lidar pairs with the pending camera frame when
///   t_lidar - pair_tolerance_us <= t_camera <= t_lidar + sweep_us + pair_tolerance_us
/// (both edges included). One camera frame waits at a time: a newer one displaces it (unpaired),
/// a sweep finds it or is unpaired itself, and a sweep that does not pair leaves it waiting for
/// the next sweep. Frames must arrive in each sensor's time order: a frame whose time is not
/// after the previous accepted frame of the same sensor (a duplicate or an earlier time) is
/// dropped and counted as out of order, changing nothing else; pairing it would record the same
/// scene twice or out of sequence.

#include <cstdint>
#include <string>

namespace calibd {

struct FramePairingConfig {
  /// How far the camera time may lie outside the sweep, us. Covers trigger jitter and residual
  /// clock offset; larger also pairs frames that did not see the same scene (at 3 m/s a board
  /// moves 6 cm in 20 ms).
  int64_t pair_tolerance_us = 20000;
  /// Duration of one LiDAR sweep, us: 1e6 / the LiDAR's frame rate (100000 at 10 Hz).
  int64_t sweep_us = 100000;

  /// pair_tolerance_us in [0, 1 s], sweep_us in (0, 1 s]; `error` names the key and the value.
  bool IsValid(std::string* error) const;
};

/// Frames seen and what became of them since construction or Reset().
struct FramePairingCounters {
  int64_t camera_frames = 0, lidar_frames = 0;  ///< OnCamera / OnLidar calls
  int64_t pairs = 0;
  /// Camera frames that never paired: displaced by a newer frame, or still pending at Flush().
  int64_t unpaired_camera = 0;
  int64_t unpaired_lidar = 0;  ///< sweeps without a pending camera frame in their window
  /// Frames dropped because their time was not after the previous accepted one of the same
  /// sensor (duplicates included).
  int64_t out_of_order_camera = 0, out_of_order_lidar = 0;
};

class FramePairer {
 public:
  struct CameraResult {
    /// False: out of order, the frame is dropped and nothing else changed. True: the frame is
    /// now the pending one, waiting for its sweep.
    bool accepted = false;
    bool displaced = false;       ///< a pending frame was dropped unpaired to make room
    int64_t displaced_utime = 0;  ///< its time, when displaced
  };
  struct LidarResult {
    bool accepted = false;  ///< false: out of order, the sweep is dropped, nothing else changed
    /// The pending camera frame lies in this sweep's window: they form a pair and nothing is
    /// pending any more. False when accepted: the sweep is unpaired and the pending frame (if
    /// any) keeps waiting.
    bool paired = false;
    int64_t camera_utime = 0;  ///< the paired camera frame's time, when paired
  };

  /// With the default config.
  FramePairer() = default;
  /// `config` must be valid (IsValid).
  explicit FramePairer(const FramePairingConfig& config);

  /// A camera frame captured at `utime` (us, mid-exposure).
  CameraResult OnCamera(int64_t utime);
  /// A LiDAR sweep starting at `utime` (us).
  LidarResult OnLidar(int64_t utime);
  /// End of the stream: a pending camera frame is dropped and counted unpaired. True if there
  /// was one.
  bool Flush();
  /// Forgets the pending camera frame without counting it, e.g. when the caller could not keep
  /// it (its own drop, counted by the caller). True if there was one.
  bool DropPending();
  /// Back to the state after construction: nothing pending, no previous times, counters zero.
  void Reset();

  bool has_pending() const { return has_pending_; }
  int64_t pending_utime() const { return pending_utime_; }  ///< meaningful when has_pending()
  const FramePairingCounters& counters() const { return counters_; }
  const FramePairingConfig& config() const { return config_; }

 private:
  FramePairingConfig config_;
  FramePairingCounters counters_;
  bool has_pending_ = false;
  int64_t pending_utime_ = 0;
  bool has_camera_ = false, has_lidar_ = false;  ///< a previous accepted frame exists
  int64_t last_camera_utime_ = 0, last_lidar_utime_ = 0;
};

}  // namespace calibd
