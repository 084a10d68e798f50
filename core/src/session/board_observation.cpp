#include "calibd/core/session/board_observation.hpp"

#include <algorithm>

namespace calibd {

void ObservationSet::Reserve(int max_observations, int max_points) {
  observations.reserve(static_cast<size_t>(max_observations));
  points.reserve(static_cast<size_t>(max_points));
  point_dt.reserve(static_cast<size_t>(max_points));
  Clear();
}

void ObservationSet::Clear() {
  observations.clear();
  points.clear();
  point_dt.clear();
  motion_compensated = false;
  time_offset_s = 0.0;
}

bool ObservationSet::Add(const BoardObservation& obs, const Eigen::Vector3f* board_points,
                         const float* dt, int count) {
  const size_t needed = points.size() + static_cast<size_t>(count);
  if (count < 0 || observations.size() + 1 > observations.capacity() ||
      needed > points.capacity() || needed > point_dt.capacity())
    return false;
  BoardObservation o = obs;
  o.first_point = static_cast<int>(points.size());
  o.num_points = count;
  points.insert(points.end(), board_points, board_points + count);
  if (dt)
    point_dt.insert(point_dt.end(), dt, dt + count);
  else
    point_dt.insert(point_dt.end(), static_cast<size_t>(count), 0.0f);
  observations.push_back(o);
  return true;
}

int ObservationSet::KeepOnly(const std::vector<char>& keep) {
  size_t kept = 0, next_point = 0;
  for (size_t i = 0; i < observations.size(); ++i) {
    if (!keep[i]) continue;
    BoardObservation o = observations[i];
    const auto first = static_cast<size_t>(o.first_point);
    const auto count = static_cast<size_t>(o.num_points);
    // Moving down never overwrites points still to be read: next_point <= first.
    std::copy(points.begin() + first, points.begin() + first + count, points.begin() + next_point);
    std::copy(point_dt.begin() + first, point_dt.begin() + first + count,
              point_dt.begin() + next_point);
    o.first_point = static_cast<int>(next_point);
    next_point += count;
    observations[kept++] = o;
  }
  const int removed = static_cast<int>(observations.size() - kept);
  observations.resize(kept);
  points.resize(next_point);
  point_dt.resize(next_point);
  return removed;
}

int ObservationSet::KeepPoints(const std::vector<char>& keep_point) {
  size_t next_point = 0;
  for (BoardObservation& o : observations) {
    const auto first = static_cast<size_t>(o.first_point);
    const auto end = first + static_cast<size_t>(o.num_points);
    o.first_point = static_cast<int>(next_point);
    // Moving down never overwrites points still to be read: next_point <= k.
    for (size_t k = first; k < end; ++k) {
      if (!keep_point[k]) continue;
      points[next_point] = points[k];
      point_dt[next_point] = point_dt[k];
      ++next_point;
    }
    o.num_points = static_cast<int>(next_point) - o.first_point;
  }
  const int removed = static_cast<int>(points.size() - next_point);
  points.resize(next_point);
  point_dt.resize(next_point);
  return removed;
}

}  // namespace calibd
