#pragma once
/// \file
/// Fixed memory for sessions of any length. The session store (SessionObservations) is sized once
/// for max_frames frame pairs; a longer session (a vehicle driving past the boards for minutes)
/// must neither grow it nor stop keeping new frames. When the store runs short of room, the kept
/// frames are thinned to every other run, and from then on only every other run of the arriving
/// frames is kept: the kept frames stay spread evenly over the whole session, however long, and
/// the store never grows. Frames are kept in runs of kRun consecutive arrivals so that motion
/// compensation (board_motion.hpp: 3 detections within +-0.25 s) still finds each kept frame's
/// neighbours.

#include <cstddef>
#include <cstdint>
#include <vector>

#include "calibd/core/session/session_observations.hpp"

namespace calibd {

/// Drops the frames whose `keep` entry is 0 (one entry per frame) and moves the rest down, in
/// order, renumbering them: no allocation, the store's capacity is unchanged.
void RemoveFrames(const std::vector<char>& keep, SessionObservations* session);

class SessionThinning {
 public:
  static constexpr int kRun = 3;  ///< consecutive arrivals kept together

  /// Starts a session whose store holds `max_frames` frames of at most `max_frame_points` points
  /// each; `headroom_frames` frames (those that can arrive before the next Apply) must always fit.
  void Reset(int max_frames, size_t max_frame_points, int headroom_frames);

  /// After frames were appended to `session` (those from `first_new` on, in arrival order):
  /// drops the new ones that are off the current stride, then, while the store could not take
  /// headroom_frames worst-case frames more, doubles the stride and drops the kept frames off it.
  void Apply(int first_new, SessionObservations* session);

  /// Runs of kRun arrivals between kept runs (1: every frame kept so far).
  int stride() const { return stride_; }
  int64_t arrivals() const { return arrivals_; }

 private:
  bool Kept(int64_t arrival) const { return (arrival / kRun) % stride_ == 0; }
  bool Room(const SessionObservations& s) const;

  int max_frames_ = 0;
  size_t max_frame_points_ = 0;
  int headroom_frames_ = 1;
  int stride_ = 1;
  int64_t arrivals_ = 0;
  std::vector<int64_t> arrival_;  ///< per kept frame: its arrival index (reserved once)
  std::vector<char> keep_;        ///< scratch, reserved once
};

}  // namespace calibd
