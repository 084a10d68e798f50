#pragma once
/// \file
/// Counts the frames missing from a periodic sensor stream from the gaps in their capture times.
/// LCM numbers no message and liblcm 1.3 counts no drop (the kernel's UDP receive buffer and
/// LCM's subscription queue both drop silently), so a lost frame shows only as a gap in its
/// sender's capture times. The period is learnt from the stream itself (the shortest interval
/// seen), so no rate needs configuring; gaps count only once a few intervals were seen.
///
/// Frames that do not move the stream forward are counted, not judged as gaps: a repeated capture
/// time (duplicates()) and a time up to kRestartUs before the latest (late(): reordered in the
/// network or by the sender). A time more than kRestartUs before the latest is the sender's clock
/// stepping back (a reset, a PTP step): like a pause longer than kRestartUs it is a restart
/// (restarts()), from which the stream is followed again; without that a clock stepped back by
/// an hour would hide every gap for an hour.

#include <cstdint>

namespace calibd {

class StreamGaps {
 public:
  /// A pause longer than this is the sensor (or the log) starting again, not lost frames: the
  /// period is learnt anew.
  static constexpr int64_t kRestartUs = 2000000;
  static constexpr int kLearnIntervals = 3;

  /// One frame's capture time (us). Returns the frames missing before it (0 for none, for the
  /// first frames, after a restart, or for a time that did not go forward).
  int Observe(int64_t utime_us) {
    const int64_t last = last_us_;
    if (last != 0 && utime_us == last) {
      ++duplicates_;
      return 0;
    }
    if (last != 0 && utime_us < last && last - utime_us <= kRestartUs) {
      ++late_;
      return 0;
    }
    last_us_ = utime_us;
    if (last == 0) return 0;
    const int64_t dt = utime_us - last;
    if (dt > kRestartUs || dt < 0) {  // a long pause, or the clock stepped back
      period_us_ = 0;
      intervals_ = 0;
      ++restarts_;
      return 0;
    }
    if (period_us_ == 0 || dt < period_us_) period_us_ = dt;
    if (++intervals_ <= kLearnIntervals) return 0;
    if (2 * dt <= 3 * period_us_) return 0;  // within 1.5 periods
    const int missing = static_cast<int>((dt + period_us_ / 2) / period_us_) - 1;
    missed_ += missing;
    return missing;
  }

  int64_t missed() const { return missed_; }
  int64_t duplicates() const { return duplicates_; }  ///< capture time equal to the latest
  int64_t late() const { return late_; }  ///< up to kRestartUs before the latest: reordered
  /// Pauses longer than kRestartUs and clock steps back by more than kRestartUs.
  int64_t restarts() const { return restarts_; }
  int64_t period_us() const { return period_us_; }

 private:
  int64_t last_us_ = 0;
  int64_t period_us_ = 0;
  int intervals_ = 0;
  int64_t missed_ = 0;
  int64_t duplicates_ = 0, late_ = 0, restarts_ = 0;
};

}  // namespace calibd
