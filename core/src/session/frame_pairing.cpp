#include "calibd/core/session/frame_pairing.hpp"

#include <cassert>
#include <limits>

namespace calibd {

namespace {

constexpr int64_t kMaxWindowUs = 1000000;  // 1 s: bounds both config values

// a + b for b >= 0, saturating instead of overflowing (times come from the network).
int64_t AddSaturating(int64_t a, int64_t b) {
  return a > std::numeric_limits<int64_t>::max() - b ? std::numeric_limits<int64_t>::max() : a + b;
}

// a - b for b >= 0, saturating.
int64_t SubtractSaturating(int64_t a, int64_t b) {
  return a < std::numeric_limits<int64_t>::min() + b ? std::numeric_limits<int64_t>::min() : a - b;
}

}  // namespace

bool FramePairingConfig::IsValid(std::string* error) const {
  auto fail = [&](const std::string& key, int64_t value, const char* what) {
    if (error) *error = key + ": must be " + what + " (got " + std::to_string(value) + ")";
    return false;
  };
  if (pair_tolerance_us < 0 || pair_tolerance_us > kMaxWindowUs)
    return fail("pair_tolerance_us", pair_tolerance_us, "in [0, 1000000] us");
  if (sweep_us <= 0 || sweep_us > kMaxWindowUs)
    return fail("sweep_us", sweep_us, "in (0, 1000000] us");
  return true;
}

FramePairer::FramePairer(const FramePairingConfig& config) : config_(config) {
  assert(config.IsValid(nullptr));
}

FramePairer::CameraResult FramePairer::OnCamera(int64_t utime) {
  ++counters_.camera_frames;
  CameraResult r;
  if (has_camera_ && utime <= last_camera_utime_) {
    ++counters_.out_of_order_camera;
    return r;
  }
  has_camera_ = true;
  last_camera_utime_ = utime;
  r.accepted = true;
  if (has_pending_) {
    ++counters_.unpaired_camera;
    r.displaced = true;
    r.displaced_utime = pending_utime_;
  }
  has_pending_ = true;
  pending_utime_ = utime;
  return r;
}

FramePairer::LidarResult FramePairer::OnLidar(int64_t utime) {
  ++counters_.lidar_frames;
  LidarResult r;
  if (has_lidar_ && utime <= last_lidar_utime_) {
    ++counters_.out_of_order_lidar;
    return r;
  }
  has_lidar_ = true;
  last_lidar_utime_ = utime;
  r.accepted = true;
  const int64_t earliest = SubtractSaturating(utime, config_.pair_tolerance_us);
  const int64_t latest = AddSaturating(utime, config_.sweep_us + config_.pair_tolerance_us);
  if (!has_pending_ || pending_utime_ < earliest || pending_utime_ > latest) {
    ++counters_.unpaired_lidar;
    return r;
  }
  ++counters_.pairs;
  r.paired = true;
  r.camera_utime = pending_utime_;
  has_pending_ = false;
  return r;
}

bool FramePairer::Flush() {
  if (!has_pending_) return false;
  ++counters_.unpaired_camera;
  has_pending_ = false;
  return true;
}

bool FramePairer::DropPending() {
  const bool had = has_pending_;
  has_pending_ = false;
  return had;
}

void FramePairer::Reset() { *this = FramePairer(config_); }

}  // namespace calibd
