#include "calibd/agent/session_recorder.hpp"

#include <algorithm>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd {

IntakeConfig IntakeConfigFrom(const AgentConfig& config) {
  IntakeConfig intake;
  intake.queue_capacity = config.intake_queue_capacity;
  intake.limits.max_width = config.calib.camera.width;
  intake.limits.max_height = config.calib.camera.height;
  intake.max_image_bytes = config.calib.camera.width * config.calib.camera.height;
  intake.pair_tolerance_us = static_cast<int64_t>(config.pair_tolerance_ms * 1000.0);
  intake.limits.max_points = config.max_points_per_sweep;
  intake.lidar.max_board_points = config.max_points_per_board;
  // The LiDAR detector keeps as many boards per sweep as the session store takes per pair.
  intake.lidar.max_boards = config.BoardsPerFrame();
  if (!config.cache_dir.empty())
    intake.reference_cache_file = config.cache_dir + "/" + AgentConfig::kReferenceCacheName;
  return intake;
}

void SessionRecorder::Init(const AgentConfig& config) {
  image_width_ = config.calib.camera.width;
  image_height_ = config.calib.camera.height;
  max_frame_points_ = static_cast<size_t>(config.BoardsPerFrame()) *
                      static_cast<size_t>(config.max_points_per_board);
  // One drain brings at most every intake slot: the store has room for that beyond max_frames,
  // so that a session of up to max_frames pairs is never thinned.
  headroom_frames_ = config.intake_queue_capacity + 1;
  max_frames_ = config.max_frames + headroom_frames_;
  session_.Reserve(max_frames_, config.BoardsPerFrame(), config.max_points_per_board);
  Clear();
}

void SessionRecorder::Clear() {
  session_.Clear();
  thinning_.Reset(max_frames_, max_frame_points_, headroom_frames_);
  figures_ = CollectionFigures{};
}

int SessionRecorder::DrainFrom(FrameIntake* intake) {
  const int first = session_.num_frames;
  const int pairs = intake->Drain(&session_);
  if (pairs > 0) {
    // Every pair counts, kept or not.
    CountCollectionFigures(session_, first, image_width_, image_height_, &figures_);
    thinning_.Apply(first, &session_);
  }
  return pairs;
}

void CountCollectionFigures(const SessionObservations& session, int first_frame, int image_width,
                            int image_height, CollectionFigures* figures) {
  // The new frames' entries are at the end of the store, in frame order.
  size_t c = session.camera.size(), l = session.lidar.size();
  while (c > 0 && session.camera[c - 1].frame >= first_frame) --c;
  while (l > 0 && session.lidar[l - 1].frame >= first_frame) --l;
  for (int f = first_frame; f < session.num_frames; ++f) {
    int cameras = 0, lidars = 0;
    for (; c < session.camera.size() && session.camera[c].frame == f; ++c) {
      const auto& cam = session.camera[c];
      ++cameras;
      const int bin = DistanceBin(cam.T_camera_board.translation().norm());
      if (bin >= 0) figures->distance_bins |= 1u << bin;
      Eigen::Vector2d centre = Eigen::Vector2d::Zero();
      for (const auto& p : cam.corners_px) centre += p / 4.0;
      const int cell = ImageCell(centre.x(), centre.y(), image_width, image_height);
      if (cell >= 0) figures->image_cells |= 1u << cell;
    }
    for (; l < session.lidar.size() && session.lidar[l].frame == f; ++l) ++lidars;
    if (cameras > 0 && lidars > 0) {
      ++figures->frames_with_boards;
      figures->boards += std::min(cameras, lidars);
    }
  }
}

}  // namespace calibd
