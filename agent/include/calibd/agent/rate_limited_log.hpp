#pragma once
/// \file
/// A rate limit for log lines about events that can come in floods (malformed messages from a
/// sensor gone wrong: at 10 Hz one line each would bury every other line of the journal). The
/// first event is logged at once; later ones at most once per interval, as one line with their
/// count. Pure logic: the caller owns the counter and the clock.

#include <cstdint>
#include <string>

namespace calibd {

class RateLimitedLog {
 public:
  static constexpr int64_t kDefaultIntervalUs = 10000000;  ///< 10 s

  explicit RateLimitedLog(int64_t interval_us = kDefaultIntervalUs) : interval_us_(interval_us) {}

  /// `total`: the events counted so far (never decreasing); `now_us`: monotonic. True when a line
  /// is due, with `*since_last` the events not yet logged; then call again at the next tick.
  bool Due(int64_t total, int64_t now_us, int64_t* since_last) {
    if (total <= logged_total_) return false;
    if (logged_ && now_us - last_line_us_ < interval_us_) return false;
    *since_last = total - logged_total_;
    logged_total_ = total;
    last_line_us_ = now_us;
    logged_ = true;
    return true;
  }

  int64_t interval_us() const { return interval_us_; }

 private:
  int64_t interval_us_;
  int64_t logged_total_ = 0;
  int64_t last_line_us_ = 0;
  bool logged_ = false;
};

/// The agent's line for `since_last` malformed messages (of `total`), `latest` the last one's
/// reason: "malformed message skipped: <latest> (1 in all)" or "<n> malformed messages skipped
/// (<total> in all), latest: <latest>".
inline std::string MalformedMessagesLine(int64_t since_last, int64_t total,
                                         const std::string& latest) {
  if (since_last == 1)
    return "malformed message skipped: " + latest + " (" + std::to_string(total) + " in all)";
  return std::to_string(since_last) + " malformed messages skipped (" + std::to_string(total) +
         " in all), latest: " + latest;
}

}  // namespace calibd
