#include "calibd/agent/frame_intake.hpp"

#include <chrono>
#include <filesystem>

#include "calibd/agent/thread_nice.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/validation.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "calibd/drivers/lidar_reference_file.hpp"

namespace calibd {

struct FrameIntake::Slot {
  SlotState state = SlotState::kFree;
  uint64_t sequence = 0;
  camera_frame_t camera;  ///< copy of the message; buffers reserved once
  lidar_frame_t lidar;
  CameraDetections camera_detections;
  LidarDetections lidar_detections;
  bool camera_done = false, lidar_done = false;
  bool camera_ok = false, lidar_ok = false;
  std::string camera_error, lidar_error;
  double camera_ms = 0.0, lidar_ms = 0.0;
  RangeImagePicture picture;  ///< IntakeConfig::debug_dir only
};

namespace {

// Copies a vector into one whose capacity was reserved: assign() reuses the storage.
template <typename T>
void CopyInto(const std::vector<T>& from, std::vector<T>* to) {
  to->assign(from.begin(), from.end());
}

}  // namespace

bool IntakeConfig::IsValid(std::string* error) const {
  if (queue_capacity < 1 || queue_capacity > 64)
    return Invalid(
        error, "queue_capacity: must be in [1, 64] (got " + std::to_string(queue_capacity) + ")");
  if (limits.max_width < 16 || limits.max_height < 16)
    return Invalid(error, "max image size: must be at least 16x16");
  if (limits.max_points < 100) return Invalid(error, "max_points: must be >= 100");
  if (max_image_bytes < 1024) return Invalid(error, "max_image_bytes: must be >= 1024");
  if (pair_tolerance_us < 0) return Invalid(error, "pair_tolerance: must be >= 0");
  std::string why;
  if (!camera.IsValid(&why)) return Invalid(error, "camera detector: " + why);
  return true;
}

FrameIntake::FrameIntake() = default;

FrameIntake::~FrameIntake() {
  cancel_build_ = true;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    stop_ = true;
  }
  work_.notify_all();
  if (camera_thread_.joinable()) camera_thread_.join();
  if (lidar_thread_.joinable()) lidar_thread_.join();
}

bool FrameIntake::Init(const IntakeConfig& config, const CalibConfig& calib, std::string* error) {
  if (!config.IsValid(error)) return false;
  LidarModel model;
  if (!LidarModelFromConfig(calib.lidar_model, calib.lidar_generic, &model, error)) return false;
  config_ = config;
  calib_ = calib;
  camera_detector_ = std::make_unique<CameraDetector>(config.camera, calib.camera, calib.boards);
  if (!camera_detector_->ok()) {
    if (error) *error = "camera detector: " + camera_detector_->error();
    return false;
  }
  lidar_config_ = config.lidar;
  lidar_config_.report_clusters = lidar_config_.report_clusters || !config.debug_dir.empty();
  lidar_model_ = model;
  std::string why;
  if (!LidarDetector::CheckInputs(lidar_config_, model, calib.boards, &why)) {
    if (error) *error = "LiDAR detector: " + why;
    return false;
  }
  startup_ = Startup();
  FramePairingConfig pairing;
  pairing.pair_tolerance_us = config.pair_tolerance_us;
  pairing.sweep_us = static_cast<int64_t>(1e6 / model.frame_rate_hz);
  pairer_ = FramePairer(pairing);

  // One slot per queued pair plus the one being filled.
  const auto points = static_cast<size_t>(config.limits.max_points);
  slots_.clear();
  for (int i = 0; i < config.queue_capacity + 1; ++i) {
    auto slot = std::make_unique<Slot>();
    // Every buffer is touched once here (resize, then clear: the capacity stays), so that the
    // first frames through a slot do not page-fault their way into it while the stream runs,
    // and the agent's resident memory is its steady one from the start.
    auto prefault = [](auto* v, size_t n) {
      v->resize(n);
      v->clear();
    };
    prefault(&slot->camera.data, static_cast<size_t>(config.max_image_bytes));
    slot->camera.camera_id.reserve(64);
    slot->lidar.lidar_id.reserve(64);
    for (auto* v : {&slot->lidar.x, &slot->lidar.y, &slot->lidar.z, &slot->lidar.intensity})
      prefault(v, points);
    prefault(&slot->lidar.ring, points);
    prefault(&slot->lidar.time_offset_us, points);
    // The detections at their largest too: a slot first used late in a session (when the
    // detectors fall behind for once) must not allocate then.
    camera_detector_->ReserveOutput(&slot->camera_detections);
    slots_.push_back(std::move(slot));
  }
  camera_decoded_.create(config.limits.max_height, config.limits.max_width, CV_8UC1);
  camera_decoded_.setTo(0);
  camera_thread_ = std::thread(&FrameIntake::Worker, this, true);
  lidar_thread_ = std::thread(&FrameIntake::Worker, this, false);
  return true;
}

void FrameIntake::SetActive(bool active) {
  std::lock_guard<std::mutex> lock(mutex_);
  if (active == active_) return;
  active_ = active;
  pairer_.Reset();
  pair_dropped_ = false;
  if (filling_ >= 0) slots_[static_cast<size_t>(filling_)]->state = SlotState::kFree;
  filling_ = -1;
}

void FrameIntake::Bad(const std::string& what) {
  ++counters_.bad_messages;
  counters_.last_error = what;
}

void FrameIntake::AfterObserve(const StreamGaps& gaps, int64_t restarts_before, bool camera) {
  (camera ? counters_.camera_duplicates : counters_.lidar_duplicates) = gaps.duplicates();
  (camera ? counters_.camera_late : counters_.lidar_late) = gaps.late();
  (camera ? counters_.camera_restarts : counters_.lidar_restarts) = gaps.restarts();
  if (!active_ || gaps.restarts() == restarts_before) return;
  // A sensor's clock stepped back (reset, PTP step) would have every later frame of it refused
  // as out of order until the old time came round again: the pairing forgets the previous times
  // (for a pause it makes no difference). A camera restart displaces the camera frame waiting for
  // its sweep (unpaired; the new frame takes its slot). On a LiDAR restart it keeps waiting: when
  // both clocks stepped, it is on the new timeline already.
  const bool pending = pairer_.has_pending();
  const int64_t pending_utime = pairer_.pending_utime();
  pairer_.Reset();
  if (pending && camera)
    ++counters_.unpaired_camera;
  else if (pending)
    pairer_.OnCamera(pending_utime);
}

int FrameIntake::FreeSlot() const {
  for (size_t i = 0; i < slots_.size(); ++i)
    if (slots_[i]->state == SlotState::kFree) return static_cast<int>(i);
  return -1;
}

void FrameIntake::OnCamera(const camera_frame_t& msg) {
  if (msg.camera_id != calib_.camera_id) return;
  std::lock_guard<std::mutex> lock(mutex_);
  ++counters_.camera_frames;
  const int64_t restarts = camera_gaps_.restarts();
  counters_.camera_missed += camera_gaps_.Observe(msg.utime);
  AfterObserve(camera_gaps_, restarts, true);
  if (!active_) {
    ++counters_.ignored_inactive;
    return;
  }
  if (!startup_.ready) {
    ++counters_.ignored_starting;
    return;
  }
  if (msg.data.size() > static_cast<size_t>(config_.max_image_bytes)) {
    Bad("camera_frame_t: " + std::to_string(msg.data.size()) +
        " bytes exceed the configured max_image_bytes " + std::to_string(config_.max_image_bytes));
    return;
  }
  const FramePairer::CameraResult r = pairer_.OnCamera(msg.utime);
  if (!r.accepted) {
    ++counters_.out_of_order;
    return;
  }
  if (r.displaced) ++counters_.unpaired_camera;
  pair_dropped_ = false;
  if (filling_ < 0) filling_ = FreeSlot();
  if (filling_ < 0) {
    // Every slot is queued or in detection: drop the newest pair, keep the queued ones.
    ++counters_.dropped_queue_full;
    pairer_.DropPending();
    pair_dropped_ = true;
    return;
  }
  Slot& slot = *slots_[static_cast<size_t>(filling_)];
  slot.state = SlotState::kFilling;
  slot.camera.utime = msg.utime;
  slot.camera.camera_id = msg.camera_id;
  slot.camera.width = msg.width;
  slot.camera.height = msg.height;
  slot.camera.stride = msg.stride;
  slot.camera.encoding = msg.encoding;
  slot.camera.size = msg.size;
  CopyInto(msg.data, &slot.camera.data);
}

void FrameIntake::OnLidar(const lidar_frame_t& msg) {
  if (msg.lidar_id != calib_.lidar_id) return;
  {
    std::lock_guard<std::mutex> lock(mutex_);
    ++counters_.lidar_frames;
    const int64_t restarts = lidar_gaps_.restarts();
    counters_.lidar_missed += lidar_gaps_.Observe(msg.utime);
    AfterObserve(lidar_gaps_, restarts, false);
    if (!active_) {
      ++counters_.ignored_inactive;
      return;
    }
    if (!startup_.ready) {
      ++counters_.ignored_starting;
      return;
    }
    if (msg.num_points < 0 || msg.num_points > config_.limits.max_points ||
        msg.x.size() > static_cast<size_t>(config_.limits.max_points)) {
      Bad("lidar_frame_t: " + std::to_string(msg.num_points) + " points exceed the sweep limit " +
          std::to_string(config_.limits.max_points) + " (agent.max_points_per_sweep)");
      return;
    }
    // Every array is copied into a slot reserved for max_points: one longer than num_points
    // (only a message built in-process can be; LCM decodes num_points of each) would grow it.
    const auto n = static_cast<size_t>(msg.num_points);
    if (msg.x.size() != n || msg.y.size() != n || msg.z.size() != n || msg.intensity.size() != n ||
        msg.ring.size() != n || msg.time_offset_us.size() != n) {
      Bad("lidar_frame_t: array lengths differ from num_points " + std::to_string(n));
      return;
    }
    const FramePairer::LidarResult r = pairer_.OnLidar(msg.utime);
    if (!r.accepted) {
      ++counters_.out_of_order;
      return;
    }
    if (!r.paired || filling_ < 0) {
      if (pair_dropped_) {
        ++counters_.pairs_formed;
        ++counters_.lidar_dropped_queue_full;
        pair_dropped_ = false;
      } else {
        ++counters_.unpaired_lidar;
      }
      return;
    }
    Slot& slot = *slots_[static_cast<size_t>(filling_)];
    slot.lidar.utime = msg.utime;
    slot.lidar.lidar_id = msg.lidar_id;
    slot.lidar.num_points = msg.num_points;
    CopyInto(msg.x, &slot.lidar.x);
    CopyInto(msg.y, &slot.lidar.y);
    CopyInto(msg.z, &slot.lidar.z);
    CopyInto(msg.intensity, &slot.lidar.intensity);
    CopyInto(msg.ring, &slot.lidar.ring);
    CopyInto(msg.time_offset_us, &slot.lidar.time_offset_us);
    slot.camera_done = slot.lidar_done = false;
    slot.sequence = next_sequence_++;
    slot.state = SlotState::kQueued;
    filling_ = -1;
    ++counters_.pairs_formed;
  }
  work_.notify_all();
}

void FrameIntake::BuildLidarDetector() {
  const auto t0 = std::chrono::steady_clock::now();
  // On a thread of its own at kReferenceBuildNice (its helper inherits it), below the detection
  // the worker goes on with (raising a nice value back would need CAP_SYS_NICE).
  // The references kept by an earlier start, when there is a cache file (no file yet: built).
  LidarReferenceSet cached;
  std::string cache_note;
  const std::string& cache_file = config_.reference_cache_file;
  const bool have_cached = !cache_file.empty() && std::filesystem::exists(cache_file) &&
                           ReadReferenceFile(cache_file, &cached, &cache_note);
  std::unique_ptr<LidarDetector> detector;
  bool niced = false;
  std::thread builder([&] {
    niced = NiceThisThread(kReferenceBuildNice);
    detector = std::make_unique<LidarDetector>(lidar_config_, lidar_model_, calib_.boards,
                                               &cancel_build_, have_cached ? &cached : nullptr);
  });
  builder.join();
  if (have_cached && !detector->references_from_cache())
    cache_note = "'" + cache_file + "' not taken: " + detector->cache_refusal();
  if (!cache_file.empty() && detector->ok() && !detector->references_from_cache()) {
    std::string error;
    const std::string written = WriteReferenceFile(cache_file, detector->references(), &error)
                                    ? "written to '" + cache_file + "'"
                                    : "not written: " + error;
    cache_note = cache_note.empty() ? written : cache_note + "; " + written;
  }
  // No slot is queued before the detector is ready (frames are ignored), so the slots' LiDAR
  // detections are this thread's alone here.
  if (detector->ok())
    for (auto& slot : slots_) detector->ReserveOutput(&slot->lidar_detections);
  {
    std::lock_guard<std::mutex> lock(mutex_);
    startup_.build_ms = MsSince(t0);
    startup_.references = detector->num_references();
    startup_.build_nice = niced ? kReferenceBuildNice : 0;
    startup_.from_cache = detector->references_from_cache();
    startup_.cache_note = cache_note;
    if (detector->ok()) {
      lidar_detector_ = std::move(detector);
      startup_.ready = true;
    } else {
      startup_.failed = true;
      startup_.error = "LiDAR detector: " + detector->error();
    }
  }
  started_.notify_all();
  if (ready_event_ != nullptr) ready_event_->Signal();
}

FrameIntake::Startup FrameIntake::startup() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return startup_;
}

bool FrameIntake::AwaitStartup() {
  std::unique_lock<std::mutex> lock(mutex_);
  started_.wait(lock, [&] { return startup_.ready || startup_.failed; });
  return startup_.ready;
}

void FrameIntake::Worker(bool camera) {
  NiceThisThread(kBackgroundNice);
  if (!camera) {
    BuildLidarDetector();
    if (!lidar_detector_) return;  // failed: the poll loop reads startup()
  }
  for (;;) {
    Slot* slot = nullptr;
    {
      std::unique_lock<std::mutex> lock(mutex_);
      // The oldest queued pair whose half for this thread is still to do.
      work_.wait(lock, [&] {
        if (stop_) return true;
        slot = nullptr;
        for (auto& s : slots_) {
          if (s->state != SlotState::kQueued || (camera ? s->camera_done : s->lidar_done)) continue;
          if (slot == nullptr || s->sequence < slot->sequence) slot = s.get();
        }
        return slot != nullptr;
      });
      if (stop_) return;
    }
    // The slot's half is ours alone until we mark it done: no lock while detecting.
    const auto t0 = std::chrono::steady_clock::now();
    if (camera) {
      ImageView view;
      slot->camera_ok = CameraFrameToView(slot->camera, config_.limits, &camera_decoded_, &view,
                                          &slot->camera_error);
      if (slot->camera_ok)
        camera_detector_->Detect(view, &slot->camera_detections, slot->camera.utime);
      slot->camera_ms = MsSince(t0);
    } else {
      PointCloudView cloud;
      slot->lidar_ok = LidarFrameToView(slot->lidar, config_.limits, &cloud, &slot->lidar_error);
      if (slot->lidar_ok) lidar_detector_->Detect(cloud, &slot->lidar_detections);
      slot->lidar_ms = MsSince(t0);
      // The picture reads the detector's range image: drawn before its next sweep.
      if (slot->lidar_ok && !config_.debug_dir.empty())
        DrawRangeImagePicture(*lidar_detector_, slot->lidar_detections, &slot->picture);
    }
    bool ready = false;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      (camera ? slot->camera_done : slot->lidar_done) = true;
      ready = slot->camera_done && slot->lidar_done;
      if (ready) slot->state = SlotState::kDone;
    }
    if (ready && ready_event_ != nullptr) ready_event_->Signal();
  }
}

int FrameIntake::Drain(SessionObservations* session) {
  std::lock_guard<std::mutex> lock(mutex_);
  int moved = 0;
  for (bool found = true; found;) {
    found = false;
    for (auto& s : slots_) {
      if (s->state != SlotState::kDone || s->sequence != drain_sequence_) continue;
      found = true;
      ++drain_sequence_;
      s->state = SlotState::kFree;
      if (session == nullptr) break;  // discarded
      if (!s->camera_ok || !s->lidar_ok) {
        Bad(!s->camera_ok ? s->camera_error : s->lidar_error);
        break;
      }
      last_camera_ms_ = s->camera_ms;
      last_lidar_ms_ = s->lidar_ms;
      const LidarDetections& lidar = s->lidar_detections;
      counters_.lidar_boards_dropped += lidar.dropped_boards;
      counters_.lidar_candidates_dropped += lidar.dropped_candidates;
      counters_.lidar_points_overflow += lidar.overflow_points;
      for (const BoardCluster& b : lidar.boards)
        if (b.cluster_points > b.num_points) ++counters_.lidar_boards_subsampled;
      if (!session->AddFrame(s->camera_detections, s->lidar_detections, calib_.boards,
                             FrameTimes{s->camera.utime, s->lidar.utime}))
        ++counters_.over_capacity;
      if (!config_.debug_dir.empty()) WriteDebug(*s);
      ++counters_.pairs_detected;
      ++moved;
      break;
    }
  }
  return moved;
}

void FrameIntake::WriteDebug(const Slot& s) {
  FrameDebugInput debug;
  debug.pair_index = static_cast<int>(counters_.pairs_detected);
  debug.camera_utime = s.camera.utime;
  debug.lidar_utime = s.lidar.utime;
  debug.lidar_points = s.lidar.num_points;
  debug.camera = &s.camera_detections;
  debug.lidar = &s.lidar_detections;
  debug.picture = &s.picture;
  std::string error;
  if (!WriteFrameDebug(config_.debug_dir, debug, &error) && counters_.debug_write_failures++ == 0)
    counters_.first_debug_error = error;
}

bool FrameIntake::Idle() const {
  std::lock_guard<std::mutex> lock(mutex_);
  for (const auto& s : slots_)
    if (s->state == SlotState::kQueued || s->state == SlotState::kDone) return false;
  return true;
}

bool FrameIntake::Full() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return !startup_.ready || (filling_ < 0 && FreeSlot() < 0);
}

}  // namespace calibd
