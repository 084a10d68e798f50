#pragma once
/// \file
/// The agent's two clocks, in microseconds: monotonic for every interval and time limit, wall
/// (CLOCK_REALTIME) only for what is stored or reported as a date.

#include <cstdint>
#include <ctime>

namespace calibd {

inline int64_t ClockUs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

inline int64_t MonotonicUs() { return ClockUs(CLOCK_MONOTONIC); }
inline int64_t WallUs() { return ClockUs(CLOCK_REALTIME); }

}  // namespace calibd
