#pragma once
/// \file
/// The agent's per-frame bookkeeping of one session: moves the detected pairs from the intake
/// into the session store, counts the collection figures (frames with boards, boards, distance
/// bins, image cells) over every pair, and thins the store when a session outgrows it
/// (core/session_thinning.hpp). Sized once from the config; allocates nothing per frame.

#include <cstddef>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/frame_intake.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/core/session/session_thinning.hpp"

namespace calibd {

/// The intake's config from the agent's (buffers sized from the camera and the board limits).
IntakeConfig IntakeConfigFrom(const AgentConfig& config);

/// Adds the frames of `session` from `first_frame` on to `figures`: a frame pair counts when both
/// sensors saw a board; the camera's boards mark their distance bin and image cell (of an image
/// `image_width` x `image_height` px). The agent's count, also run by the fault campaign.
void CountCollectionFigures(const SessionObservations& session, int first_frame, int image_width,
                            int image_height, CollectionFigures* figures);

class SessionRecorder {
 public:
  /// Reserves the store from the config (max_frames, boards per frame, points per board).
  void Init(const AgentConfig& config);
  /// Starts a new session: empty store, figures at zero.
  void Clear();
  /// Drains the intake's finished pairs into the store; returns how many came.
  int DrainFrom(FrameIntake* intake);

  const SessionObservations& session() const { return session_; }
  const CollectionFigures& figures() const { return figures_; }
  const SessionThinning& thinning() const { return thinning_; }

 private:
  int image_width_ = 0, image_height_ = 0;
  int max_frames_ = 0;
  size_t max_frame_points_ = 0;
  int headroom_frames_ = 1;
  SessionObservations session_;
  SessionThinning thinning_;
  CollectionFigures figures_;
};

}  // namespace calibd
