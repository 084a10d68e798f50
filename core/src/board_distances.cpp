#include "calibd/core/board_distances.hpp"

#include "calibd/core/stats.hpp"

namespace calibd {

std::vector<BoardDistance> BoardDistances(const ObservationSet& set, const Pose& T_camera_lidar) {
  std::vector<BoardDistance> out;
  out.reserve(set.observations.size());
  std::vector<double> along;
  const Eigen::Vector3d lidar_origin = T_camera_lidar.translation();
  for (const BoardObservation& o : set.observations) {
    if (o.num_points < kMinBoardDistancePoints) continue;
    BoardDistance b;
    b.observation = &o;
    b.normal = o.T_camera_board.linear().col(2);
    b.camera_m = b.normal.dot(o.T_camera_board.translation());
    if (b.camera_m < 0.0) {
      b.normal = -b.normal;
      b.camera_m = -b.camera_m;
    }
    along.clear();
    Eigen::Vector3d ray = Eigen::Vector3d::Zero();
    for (int p = 0; p < o.num_points; ++p) {
      const Eigen::Vector3d p_camera =
          T_camera_lidar * set.points[static_cast<size_t>(o.first_point + p)].cast<double>();
      along.push_back(b.normal.dot(p_camera));
      ray += (p_camera - lidar_origin).normalized();
    }
    b.lidar_m = Quantile(along, 0.5);
    b.mean_ray = ray.normalized();
    double side_px = 0.0;
    for (int c = 0; c < 4; ++c) side_px += (o.corners_px[c] - o.corners_px[(c + 1) % 4]).norm();
    const double d = o.T_camera_board.translation().norm();
    b.weight = d > 0.0 && side_px > 0.0 ? side_px / 4.0 / d : 0.0;
    if (!(b.weight > 0.0) || !std::isfinite(b.weight)) continue;
    out.push_back(b);
  }
  return out;
}

}  // namespace calibd
