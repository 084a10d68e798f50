#include "calibd/core/session/board_distances.hpp"

#include <algorithm>

#include "calibd/core/common/stats.hpp"

namespace calibd {
namespace {
// The in-plane centre's grid: about this many points a cell, at most this many cells a side.
constexpr double kPointsPerCell = 6.0;
constexpr int kMaxCellsPerSide = 12;
// The in-plane centre counts the points within this many sigmas (the board's own scatter along
// its normal, from the median absolute deviation) of its plane, and never less than
// kMinPlaneBandM: a return mixed from a board's edge and what lies behind it sits off the plane,
// and projected onto it along a slanted ray lands beyond the edge on one side only.
constexpr double kPlaneBandSigmas = 3.0;
constexpr double kMinPlaneBandM = 0.01;
}  // namespace

std::vector<BoardDistance> BoardDistances(const ObservationSet& set, const Pose& T_camera_lidar,
                                          const std::vector<BoardGeometry>* boards) {
  std::vector<BoardDistance> out;
  out.reserve(set.observations.size());
  std::vector<double> along;
  struct Inside {
    Eigen::Vector2d xy;
    Eigen::Vector3d ray;
    double along;  // normal . p
  };
  struct Cell {
    Eigen::Vector2d xy = Eigen::Vector2d::Zero();
    Eigen::Vector3d ray = Eigen::Vector3d::Zero();
    int count = 0;
  };
  std::vector<Inside> inside;
  std::vector<Cell> cells;
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
    inside.clear();
    Eigen::Vector3d ray = Eigen::Vector3d::Zero();
    const Pose T_board_camera = o.T_camera_board.inverse();
    Eigen::Vector2d half = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
    if (boards) {
      const BoardGeometry& g = (*boards)[static_cast<size_t>(o.board_index)];
      half =
          Eigen::Vector2d(g.width_m, g.height_m) / 2.0 + Eigen::Vector2d::Constant(kCentroidMargin);
    }
    for (int p = 0; p < o.num_points; ++p) {
      const Eigen::Vector3d p_camera =
          T_camera_lidar * set.points[static_cast<size_t>(o.first_point + p)].cast<double>();
      along.push_back(b.normal.dot(p_camera));
      const Eigen::Vector3d u = (p_camera - lidar_origin).normalized();
      ray += u;
      const Eigen::Vector2d in_board = (T_board_camera * p_camera).head<2>();
      if (std::fabs(in_board.x()) > half.x() || std::fabs(in_board.y()) > half.y()) continue;
      inside.push_back({in_board, u, along.back()});
    }
    if (inside.empty() || !ray.allFinite()) continue;
    b.lidar_m = Quantile(along, 0.5);
    b.mean_ray = ray.normalized();
    for (double& a : along) a = std::fabs(a - b.lidar_m);
    constexpr double kMadToSigma = 1.4826;
    const double band =
        std::max(kMinPlaneBandM, kPlaneBandSigmas * kMadToSigma * Quantile(along, 0.5));
    inside.erase(
        std::remove_if(inside.begin(), inside.end(),
                       [&](const Inside& p) { return std::fabs(p.along - b.lidar_m) > band; }),
        inside.end());
    if (inside.empty()) continue;
    // The in-plane centre: the mean over the occupied cells of a grid on the board of each cell's
    // mean point, so that where the scan puts its points more densely (a rosette's centre, a
    // ring LiDAR's denser rings, the nearer side) weighs no more. About kPointsPerCell points a
    // cell, so that the sparser parts leave no holes; one cell without the outline.
    const int n =
        std::isfinite(half.x())
            ? std::clamp(
                  static_cast<int>(std::sqrt(static_cast<double>(inside.size()) / kPointsPerCell)),
                  1, kMaxCellsPerSide)
            : 1;
    // The grid spans the points' own extent, so that it moves with them: on a grid fixed to the
    // board, a full cell's mean would stay at its centre when the points move, and the centre
    // would follow a range offset only through the edge cells.
    Eigen::Vector2d lo = inside[0].xy, hi = inside[0].xy;
    for (const Inside& p : inside) {
      lo = lo.cwiseMin(p.xy);
      hi = hi.cwiseMax(p.xy);
    }
    const Eigen::Vector2d extent = (hi - lo).cwiseMax(Eigen::Vector2d::Constant(1e-9));
    cells.assign(static_cast<size_t>(n * n), Cell{});
    for (const Inside& p : inside) {
      const auto index = [&](int axis) {
        return std::clamp(static_cast<int>((p.xy(axis) - lo(axis)) / extent(axis) * n), 0, n - 1);
      };
      Cell& c = cells[static_cast<size_t>(index(1) * n + index(0))];
      c.xy += p.xy;
      c.ray += p.ray;
      ++c.count;
    }
    Eigen::Vector2d xy = Eigen::Vector2d::Zero();
    Eigen::Vector3d cell_ray = Eigen::Vector3d::Zero();
    int occupied = 0;
    for (const Cell& c : cells) {
      if (c.count == 0) continue;
      xy += c.xy / c.count;
      cell_ray += c.ray / c.count;
      ++occupied;
    }
    b.lidar_in_plane = xy / occupied;
    b.mean_ray_area = cell_ray / occupied;
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
