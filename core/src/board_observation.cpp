#include "calibd/core/board_observation.hpp"

namespace calibd {

bool ObservationSet::Add(const BoardObservation& obs, const Eigen::Vector3f* board_points,
                         int count) {
  if (count < 0 || observations.size() + 1 > observations.capacity() ||
      points.size() + static_cast<size_t>(count) > points.capacity())
    return false;
  BoardObservation o = obs;
  o.first_point = static_cast<int>(points.size());
  o.num_points = count;
  points.insert(points.end(), board_points, board_points + count);
  observations.push_back(o);
  return true;
}

}  // namespace calibd
