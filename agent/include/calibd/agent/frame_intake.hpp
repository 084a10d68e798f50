#pragma once
/// \file
/// The agent's streaming intake: camera and LiDAR messages from the poll loop are paired by time,
/// copied into one of a fixed ring of frame slots and detected on two worker threads (camera and
/// LiDAR detection run in parallel, each detector owned by its thread); the poll loop then drains
/// the finished pairs, in arrival order, into the session's observations. Only the compact
/// observations outlive a slot.
///
/// Fixed memory: every slot's buffers (encoded image, point arrays, detections) and the camera
/// thread's one decoded image are sized once in Init from the limits; nothing grows with the number
/// of frames. A message larger than the limits is refused (counted, with the reason in last_error),
/// never grown into.
///
/// Drop policy: when every slot is queued or in detection, a newly arriving camera frame (and so
/// its pair) is dropped: the newest data is dropped, the queued pairs are kept (counted in
/// dropped_queue_full). A camera frame not followed by a LiDAR sweep that pairs with it is
/// replaced by the next camera frame (unpaired_camera); a sweep without a camera frame in its
/// window is skipped (unpaired_lidar).

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "calibd/camera_frame_t.hpp"
#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/core/session/frame_pairing.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/core/session/stream_gaps.hpp"
#include "calibd/drivers/frame_debug.hpp"
#include "calibd/drivers/lcm_frames.hpp"
#include "calibd/drivers/wake_event.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd {

struct IntakeConfig {
  /// Frame pairs that may wait for or be in detection at once. More absorb longer stalls of the
  /// detectors at the cost of one image and one sweep buffer each (about 7 + 7 MB at
  /// 3840x1920 mono8 and 300k points).
  int queue_capacity = 4;
  FrameLimits limits{3840, 2160, 400000};  ///< largest image (pixels) and sweep (points) accepted
  /// Largest encoded image (bytes): mono8 needs width x height, JPEG less, bgr8 three times.
  int max_image_bytes = 3840 * 2160;
  int64_t pair_tolerance_us = 20000;  ///< camera time allowed outside the LiDAR sweep
  CameraDetectorConfig camera;
  LidarDetectorConfig lidar;
  /// Replays only (calibd-agent --debug): a directory receiving, per pair drained, what the
  /// detectors made of it (calibd/drivers/frame_debug.hpp; the LiDAR's cluster reports are
  /// turned on). Empty: nothing written.
  std::string debug_dir;
  /// The file keeping the LiDAR detector's reference descriptors between starts
  /// (drivers/lidar_reference_file.hpp; AgentConfig::cache_dir): read before the build, which it
  /// replaces when it fits the config, model and boards; written after a build. Empty: none.
  std::string reference_cache_file;

  bool IsValid(std::string* error) const;
};

struct IntakeCounters {
  int64_t camera_frames = 0, lidar_frames = 0;  ///< messages for the configured sensors
  int64_t pairs_detected = 0;                   ///< pairs drained into the session
  /// Camera frames and sweeps whose capture times paired (queued for detection, or dropped with
  /// a full queue): the streams pair, however long detection takes.
  int64_t pairs_formed = 0;
  int64_t dropped_queue_full = 0;  ///< pairs dropped: every slot busy
  /// Sweeps lost with their pair: the camera frame they would pair with was dropped (queue full).
  int64_t lidar_dropped_queue_full = 0;
  /// Frames missing from each stream before the agent (network, LCM queue), from the gaps in
  /// their capture times (stream_gaps.hpp); counted whether collecting or not.
  int64_t camera_missed = 0, lidar_missed = 0;
  /// Per sensor, from the capture times too (stream_gaps.hpp), whether collecting or not: a time
  /// equal to the latest (duplicates), up to 2 s before it (late: reordered), and restarts (a
  /// pause of more than 2 s, or the sensor's clock stepping back by more than 2 s). A received
  /// frame that is a duplicate or late is one the stream had already sent or was counted missing
  /// for, so frames sent = received + missed - duplicates - late (within one stream timeline).
  int64_t camera_duplicates = 0, lidar_duplicates = 0;
  int64_t camera_late = 0, lidar_late = 0;
  int64_t camera_restarts = 0, lidar_restarts = 0;
  int64_t unpaired_camera = 0, unpaired_lidar = 0;
  /// Timestamps that went backwards or repeated while collecting, skipped by the pairing (a
  /// sensor's clock stepping back by more than 2 s instead restarts the pairing: see above).
  int64_t out_of_order = 0;
  int64_t bad_messages = 0;   ///< malformed or beyond the limits, skipped
  int64_t over_capacity = 0;  ///< pairs whose observations did not fit the session store
  /// The LiDAR detector's fixed capacities (LidarDetectorConfig), summed over the pairs drained:
  /// boards beyond max_boards and gated clusters beyond max_clusters (dropped), points beyond
  /// max_points (not looked at), and boards whose cluster had more than max_board_points
  /// (agent.max_points_per_board: kept as an even subsample).
  int64_t lidar_boards_dropped = 0, lidar_candidates_dropped = 0;
  int64_t lidar_points_overflow = 0, lidar_boards_subsampled = 0;
  int64_t ignored_inactive = 0;  ///< frames received while not collecting
  /// Frames received while collecting but before the LiDAR detector was built (FrameIntake::Init).
  int64_t ignored_starting = 0;
  std::string last_error;            ///< what was wrong with the latest bad message
  int64_t debug_write_failures = 0;  ///< IntakeConfig::debug_dir files not written
  std::string first_debug_error;
};

class FrameIntake {
 public:
  FrameIntake();
  ~FrameIntake();  ///< stops and joins the workers
  FrameIntake(const FrameIntake&) = delete;
  FrameIntake& operator=(const FrameIntake&) = delete;

  /// Checks both detectors' inputs, builds the camera detector, the slots and the two worker
  /// threads. False with `error` naming what is wrong (config, intrinsics, boards, model). The
  /// LiDAR worker then builds the LiDAR detector first: its reference descriptors take about a
  /// second on one core of a PC, many times that on an embedded CPU or in an emulator, and a
  /// daemon must answer its diagnostics meanwhile. Until it is ready (Startup()), frames are
  /// counted in ignored_starting and Full() holds a replay back.
  bool Init(const IntakeConfig& config, const CalibConfig& calib, std::string* error);

  /// Where the LiDAR detector's build stands: ready, or failed with the reason (no reference
  /// board has enough points under this LiDAR model), with its time and reference count.
  struct Startup {
    bool ready = false;
    bool failed = false;
    std::string error;
    double build_ms = 0.0;
    int references = 0;
    int build_nice = 0;  ///< the build thread's nice value (0: setpriority was refused)
    /// The references came from IntakeConfig::reference_cache_file.
    bool from_cache = false;
    /// What became of the cache when it was not used as is: why the file was not taken, or that
    /// it was written, or why not (empty without a cache file).
    std::string cache_note;
  };
  Startup startup() const;
  /// Blocks until the LiDAR detector is built or failed; true when ready. For programs that feed
  /// frames without a poll loop (tests, benches).
  bool AwaitStartup();

  /// While inactive, messages are only counted (ignored_inactive), nothing is detected. Turning
  /// it on starts a fresh pairing; turning it off drops a half-filled pair (queued pairs are
  /// still detected and can be drained).
  void SetActive(bool active);
  bool active() const { return active_; }

  /// Poll thread: one decoded message. Messages of other sensor ids are ignored.
  void OnCamera(const camera_frame_t& msg);
  void OnLidar(const lidar_frame_t& msg);

  /// Poll thread: moves finished pairs, oldest first, into `session` (AddFrame); returns the
  /// number moved. Pairs that do not fit are counted in over_capacity. With a null `session` the
  /// finished pairs are discarded (frames still in flight when a collection ended).
  int Drain(SessionObservations* session);
  /// Signalled by the workers whenever a pair is ready to drain, so that the poll loop drains it
  /// at once instead of at its next timer tick (null: none). Set before Init; must outlive the
  /// intake.
  void SetReadyEvent(const WakeEvent* event) { ready_event_ = event; }
  /// True when no pair is queued or in detection (everything received has been drained).
  bool Idle() const;
  /// True when a new camera frame would find no free slot (it would be dropped). A replay that
  /// may wait (file://) holds back its reading while Full(); a live stream does not wait.
  bool Full() const;

  const IntakeCounters& counters() const { return counters_; }
  /// Detection time of the last drained pair, per sensor (ms), for health reports.
  double last_camera_ms() const { return last_camera_ms_; }
  double last_lidar_ms() const { return last_lidar_ms_; }

 private:
  struct Slot;
  enum class SlotState { kFree, kFilling, kQueued, kDone };
  void Worker(bool camera);
  /// LiDAR worker, first: builds the detector and reserves every slot's LiDAR detections.
  void BuildLidarDetector();
  void Bad(const std::string& what);
  /// After `gaps` observed a frame: copies its counts into the counters and, when the frame was
  /// a clock step back while collecting, restarts the pairing on the new timeline.
  void AfterObserve(const StreamGaps& gaps, int64_t restarts_before, bool camera);
  int FreeSlot() const;
  /// Writes the debug files of a drained pair (IntakeConfig::debug_dir).
  void WriteDebug(const Slot& s);

  IntakeConfig config_;
  CalibConfig calib_;
  std::unique_ptr<CameraDetector> camera_detector_;
  LidarDetectorConfig lidar_config_;
  LidarModel lidar_model_;
  std::unique_ptr<LidarDetector> lidar_detector_;  ///< set by the LiDAR worker (BuildLidarDetector)
  Startup startup_;                                ///< under mutex_
  std::atomic<bool> cancel_build_{false};          ///< the destructor stops a build still running
  std::condition_variable started_;
  std::vector<std::unique_ptr<Slot>> slots_;
  /// JPEG and bgr8 frames are decoded here (camera thread only; allocated once at the largest
  /// size): one image per thread, not per slot, since a slot's image is decoded only while its
  /// detection runs (7.4 MB per slot saved at 3840x1920).
  cv::Mat camera_decoded_;
  FramePairer pairer_;
  StreamGaps camera_gaps_, lidar_gaps_;
  bool pair_dropped_ = false;    ///< the pending camera frame was dropped: its sweep goes too
  int filling_ = -1;             ///< slot holding the camera frame waiting for its sweep
  uint64_t next_sequence_ = 0;   ///< arrival order of queued pairs
  uint64_t drain_sequence_ = 0;  ///< next pair to drain
  bool active_ = false;
  const WakeEvent* ready_event_ = nullptr;
  IntakeCounters counters_;
  double last_camera_ms_ = 0.0, last_lidar_ms_ = 0.0;

  mutable std::mutex mutex_;
  std::condition_variable work_;
  bool stop_ = false;
  std::thread camera_thread_, lidar_thread_;
};

}  // namespace calibd
