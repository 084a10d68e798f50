#include "calibd/core/session/static_scenery.hpp"

#include <Eigen/Core>
#include <algorithm>
#include <cmath>

#include "calibd/core/common/validation.hpp"
#include "calibd/core/lidar/cluster_pca.hpp"

namespace calibd {

namespace {

struct ClusterPlane {
  int frame = 0;
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  Eigen::Vector3d normal = Eigen::Vector3d::UnitX();
};

// What two frames say about one object seen in both.
enum class Evidence { kNone, kScenery, kBoard };

}  // namespace

bool StaticSceneryConfig::IsValid(std::string* error) const {
  if (!(max_normal_angle_deg > 0.0 && max_normal_angle_deg < 90.0))
    return Invalid(error, "max_normal_angle_deg: must be in (0, 90)");
  if (!(max_plane_distance_m > 0.0 && max_plane_distance_m < 1.0))
    return Invalid(error, "max_plane_distance_m: must be in (0, 1) m");
  if (min_frames < 1) return Invalid(error, "min_frames: must be >= 1");
  return true;
}

StaticScenery FindStaticScenery(const SessionObservations& session,
                                const std::vector<BoardGeometry>& boards,
                                const StaticSceneryConfig& config) {
  StaticScenery out;
  out.scenery.assign(session.lidar.size(), 0);
  if (!config.enabled || boards.empty() || session.lidar.size() < 2) return out;
  double min_side = 1e300;
  for (const BoardGeometry& g : boards) min_side = std::min({min_side, g.width_m, g.height_m});
  const double same_object_m = 0.5 * min_side;
  const double cos_normal = std::cos(config.max_normal_angle_deg * kDeg2Rad);

  std::vector<ClusterPlane> planes(session.lidar.size());
  for (size_t i = 0; i < planes.size(); ++i) {
    const SessionObservations::LidarCluster& c = session.lidar[i];
    ClusterPca pca;
    ComputeClusterPca(session.points.data() + c.first_point, c.num_points, &pca);
    planes[i] = {c.frame, pca.centroid, pca.axes.col(2)};
  }
  // Per frame, the camera's boards: where each entry of session.camera starts.
  std::vector<int> camera_begin(static_cast<size_t>(session.num_frames) + 1, 0);
  for (const auto& b : session.camera) ++camera_begin[static_cast<size_t>(b.frame) + 1];
  for (size_t f = 1; f < camera_begin.size(); ++f) camera_begin[f] += camera_begin[f - 1];

  auto evidence = [&](int f, int g, double lidar_moved_m) {
    Evidence e = Evidence::kNone;
    for (int a = camera_begin[f]; a < camera_begin[f + 1]; ++a) {
      for (int b = camera_begin[g]; b < camera_begin[g + 1]; ++b) {
        const auto& ca = session.camera[static_cast<size_t>(a)];
        const auto& cb = session.camera[static_cast<size_t>(b)];
        if (ca.board_index != cb.board_index) continue;
        const double moved =
            (ca.T_camera_board.translation() - cb.T_camera_board.translation()).norm();
        if (moved <= lidar_moved_m + same_object_m) return Evidence::kBoard;
        e = Evidence::kScenery;
      }
    }
    return e;
  };

  for (size_t i = 0; i < planes.size(); ++i) {
    int scenery = 0, board = 0;
    int last_frame = -1;  // clusters come in frame order: each other frame counts once
    for (size_t j = 0; j < planes.size(); ++j) {
      const ClusterPlane& p = planes[i];
      const ClusterPlane& q = planes[j];
      if (p.frame == q.frame || q.frame == last_frame) continue;
      const Eigen::Vector3d d = q.centroid - p.centroid;
      const double moved = d.norm();
      if (moved > same_object_m || std::fabs(p.normal.dot(q.normal)) < cos_normal ||
          std::fabs(p.normal.dot(d)) > config.max_plane_distance_m ||
          std::fabs(q.normal.dot(d)) > config.max_plane_distance_m)
        continue;
      last_frame = q.frame;
      const Evidence e = evidence(p.frame, q.frame, moved);
      scenery += e == Evidence::kScenery ? 1 : 0;
      board += e == Evidence::kBoard ? 1 : 0;
    }
    if (scenery >= config.min_frames && scenery > board) {
      out.scenery[i] = 1;
      ++out.num_scenery;
    }
  }
  return out;
}

}  // namespace calibd
