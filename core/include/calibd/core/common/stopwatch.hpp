#pragma once
/// \file
/// Elapsed steady-clock time in milliseconds: the timing figures results and benchmarks carry
/// (DirectResult::solve_ms, the agent's start-up, per-stage times).

#include <chrono>

namespace calibd {

using SteadyClock = std::chrono::steady_clock;

/// Milliseconds from `a` to `b`.
inline double MsBetween(SteadyClock::time_point a, SteadyClock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

/// Milliseconds from `t0` to now.
inline double MsSince(SteadyClock::time_point t0) { return MsBetween(t0, SteadyClock::now()); }

/// Seconds from `t0` to now (whole runs: a drive's detection, a campaign's sessions).
inline double SecondsSince(SteadyClock::time_point t0) {
  return std::chrono::duration<double>(SteadyClock::now() - t0).count();
}

}  // namespace calibd
