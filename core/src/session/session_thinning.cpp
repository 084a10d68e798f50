#include "calibd/core/session/session_thinning.hpp"

#include <algorithm>

namespace calibd {

void RemoveFrames(const std::vector<char>& keep, SessionObservations* s) {
  // New number of every frame (-1: dropped).
  int kept = 0;
  size_t c = 0, l = 0, out_c = 0, out_l = 0, out_p = 0;
  for (int f = 0; f < s->num_frames; ++f) {
    const bool k = keep[static_cast<size_t>(f)] != 0;
    for (; c < s->camera.size() && s->camera[c].frame == f; ++c) {
      if (!k) continue;
      s->camera[out_c] = s->camera[c];
      s->camera[out_c++].frame = kept;
    }
    for (; l < s->lidar.size() && s->lidar[l].frame == f; ++l) {
      if (!k) continue;
      SessionObservations::LidarCluster cl = s->lidar[l];
      const auto first = static_cast<size_t>(cl.first_point);
      const auto n = static_cast<size_t>(cl.num_points);
      // Moving down (out_p <= first): std::copy is safe for overlapping ranges in this direction.
      std::copy(s->points.begin() + first, s->points.begin() + first + n,
                s->points.begin() + out_p);
      if (s->point_dt.size() == s->points.size())
        std::copy(s->point_dt.begin() + first, s->point_dt.begin() + first + n,
                  s->point_dt.begin() + out_p);
      cl.first_point = static_cast<int>(out_p);
      cl.frame = kept;
      s->lidar[out_l++] = cl;
      out_p += n;
    }
    if (k) s->frame_times[static_cast<size_t>(kept++)] = s->frame_times[static_cast<size_t>(f)];
  }
  const bool has_dt = s->point_dt.size() == s->points.size();
  s->camera.resize(out_c);
  s->lidar.resize(out_l);
  s->points.resize(out_p);
  if (has_dt) s->point_dt.resize(out_p);
  s->frame_times.resize(static_cast<size_t>(kept));
  s->num_frames = kept;
}

void SessionThinning::Reset(int max_frames, size_t max_frame_points, int headroom_frames) {
  max_frames_ = max_frames;
  max_frame_points_ = max_frame_points;
  headroom_frames_ = std::max(1, headroom_frames);
  stride_ = 1;
  arrivals_ = 0;
  arrival_.clear();
  arrival_.reserve(static_cast<size_t>(max_frames));
  keep_.clear();
  keep_.reserve(static_cast<size_t>(max_frames));
}

bool SessionThinning::Room(const SessionObservations& s) const {
  const size_t free_points = s.points.capacity() - s.points.size();
  return s.num_frames + headroom_frames_ <= max_frames_ &&
         free_points >= static_cast<size_t>(headroom_frames_) * max_frame_points_;
}

void SessionThinning::Apply(int first_new, SessionObservations* s) {
  // The new frames: number their arrivals, drop those off the stride.
  arrival_.resize(static_cast<size_t>(first_new));
  keep_.assign(static_cast<size_t>(s->num_frames), 1);
  bool drop = false;
  for (int f = first_new; f < s->num_frames; ++f) {
    const int64_t a = arrivals_++;
    if (Kept(a)) {
      arrival_.push_back(a);
    } else {
      keep_[static_cast<size_t>(f)] = 0;
      drop = true;
    }
  }
  if (drop) RemoveFrames(keep_, s);
  // Short of room: every other run of the kept frames goes, and so will every other run to come.
  while (!Room(*s) && s->num_frames > 0) {
    stride_ *= 2;
    keep_.assign(static_cast<size_t>(s->num_frames), 0);
    size_t out = 0;
    for (size_t f = 0; f < arrival_.size(); ++f) {
      if (!Kept(arrival_[f])) continue;
      keep_[f] = 1;
      arrival_[out++] = arrival_[f];
    }
    arrival_.resize(out);
    RemoveFrames(keep_, s);
  }
}

}  // namespace calibd
