#pragma once
/// \file
/// The session's solve on a thread of its own, so that the poll loop keeps answering diagnostics
/// and publishing status while the engine works (calibration_engine.hpp). One solve at a time;
/// its outcome is the poll loop's once collected, and stays until the next session starts.

#include <atomic>
#include <cstdint>
#include <thread>

#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/drivers/wake_event.hpp"

namespace calibd {

class SolveRunner {
 public:
  SolveRunner() = default;
  ~SolveRunner();
  SolveRunner(const SolveRunner&) = delete;
  SolveRunner& operator=(const SolveRunner&) = delete;

  /// Solves `session`'s `observations` at kBackgroundNice. They, `projection` and `engine` are
  /// read by the solve thread until it finishes: the caller leaves them unchanged until then.
  /// `wake` is signalled when it finishes. Only when nothing is pending().
  void Start(int session, const CalibConfig& calib, const SessionObservations& observations,
             const RangeImage& projection, const EngineConfig& engine, WakeEvent* wake,
             int64_t now_us);
  /// A solve was started and its outcome not collected (running or finished).
  bool pending() const { return thread_.joinable(); }
  /// A solve is still running.
  bool running() const { return pending() && !done_; }
  /// A solve finished and waits for Collect.
  bool finished() const { return pending() && done_; }
  /// Takes a finished solve's outcome: outcome() from now on.
  void Collect();
  /// A new session: forgets the last outcome, and a finished solve no one collected (one of an
  /// aborted session). Not while running().
  void Clear();

  /// The collected outcome, null before the session's solve was collected.
  const CalibrationOutcome* outcome() const { return has_outcome_ ? &outcome_ : nullptr; }
  /// The session the last solve was started for, and when (monotonic).
  int session() const { return session_; }
  int64_t started_us() const { return started_us_; }

 private:
  std::thread thread_;
  std::atomic<bool> done_{false};
  int session_ = 0;
  int64_t started_us_ = 0;
  CalibrationOutcome outcome_;  ///< written by the thread until done_, then by no one
  bool has_outcome_ = false;
};

}  // namespace calibd
