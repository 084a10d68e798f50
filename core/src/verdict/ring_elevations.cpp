#include "calibd/core/verdict/ring_elevations.hpp"

#include <algorithm>
#include <cmath>

namespace calibd {

namespace {

/// A ring's fit needs at least this many points and this much leverage (sum of g^2, m^2: e.g.
/// 20 points at 5 m with n . e_el = 0.3).
constexpr int kMinRingPoints = 30;
constexpr double kMinLeverage = 20.0 * 2.25;
/// The check needs this many measured rings to tell a laser's error from the rest.
constexpr int kMinRingsMeasured = 4;
/// Points beyond this share of a board's half size are left out (edges, mixed returns).
constexpr double kInnerShare = 0.9;

struct Sums {
  double gg = 0.0, gd = 0.0, dd = 0.0;
  int n = 0;
};

}  // namespace

RingElevationCheck CheckRingElevations(const std::vector<BoardGeometry>& boards,
                                       const ObservationSet& set, const RangeImage& projection,
                                       const Pose& T_camera_lidar,
                                       const std::vector<Pose>& T_camera_board) {
  RingElevationCheck out;
  if (!projection.has_rings() || projection.rows() <= 0) return out;
  const auto rows = static_cast<size_t>(projection.rows());
  const bool refined = T_camera_board.size() == set.observations.size();
  std::vector<Sums> total(rows);
  // Per ring, the per-observation deltas (with their least-squares weight) for the scatter.
  std::vector<std::vector<std::pair<double, double>>> per_observation(rows);
  std::vector<Sums> obs(rows);
  for (size_t i = 0; i < set.observations.size(); ++i) {
    const BoardObservation& o = set.observations[i];
    if (o.board_index < 0 || o.board_index >= static_cast<int>(boards.size())) continue;
    const BoardGeometry& g = boards[static_cast<size_t>(o.board_index)];
    const Pose T_lidar_board =
        T_camera_lidar.inverse() * (refined ? T_camera_board[i] : o.T_camera_board);
    const Pose T_board_lidar = T_lidar_board.inverse();
    const Eigen::Vector3d n = T_lidar_board.linear().col(2);
    const double offset = n.dot(T_lidar_board.translation());
    std::fill(obs.begin(), obs.end(), Sums{});
    for (int k = 0; k < o.num_points; ++k) {
      const Eigen::Vector3d p = set.points[static_cast<size_t>(o.first_point + k)].cast<double>();
      // Inside the board where the point's ray meets the board's plane, not where the point lies:
      // its range noise moves it along the ray, and a ray slanted to the board carries it across
      // the inner part's edge, so a cut on the point would keep the short returns of the rings
      // along one edge and the long ones along the other (a ring biased by the cut alone).
      const double along = n.dot(p);
      if (!(along * offset > 0.0)) continue;
      const Eigen::Vector3d b = T_board_lidar * (p * (offset / along));
      if (std::abs(b.x()) > kInnerShare * g.width_m / 2.0 ||
          std::abs(b.y()) > kInnerShare * g.height_m / 2.0)
        continue;
      const double r = p.norm(), rho = std::hypot(p.x(), p.y());
      if (r <= 0.0 || rho <= 0.0) continue;
      const double azimuth = std::atan2(p.y(), p.x()), elevation = std::atan2(p.z(), rho);
      int row = -1, col = -1;
      if (!projection.CellOf(azimuth, elevation, &row, &col)) continue;
      // Upward unit vector along the meridian of the point's direction.
      const Eigen::Vector3d e_el(-p.z() * p.x() / (r * rho), -p.z() * p.y() / (r * rho), rho / r);
      const double gk = r * n.dot(e_el), d = n.dot(p) - offset;
      Sums& s = obs[static_cast<size_t>(row)];
      s.gg += gk * gk;
      s.gd += gk * d;
      s.dd += d * d;
      ++s.n;
    }
    for (size_t r = 0; r < rows; ++r) {
      const Sums& s = obs[r];
      if (s.n == 0) continue;
      Sums& t = total[r];
      t.gg += s.gg;
      t.gd += s.gd;
      t.dd += s.dd;
      t.n += s.n;
      if (s.n >= 3 && s.gg > 0.0) per_observation[r].emplace_back(s.gd / s.gg, s.gg);
    }
  }
  // Per ring: delta and its sigma.
  std::vector<double> delta(rows, 0.0), sigma(rows, std::numeric_limits<double>::infinity());
  for (size_t r = 0; r < rows; ++r) {
    const Sums& t = total[r];
    if (t.n < kMinRingPoints || t.gg < kMinLeverage) continue;
    delta[r] = t.gd / t.gg;
    const double rss = std::max(0.0, t.dd - delta[r] * t.gd);
    double s2 = rss / std::max(1, t.n - 1) / t.gg;
    const auto& po = per_observation[r];
    if (po.size() >= 3) {
      // Weighted scatter of the observations' deltas about the ring's, over their count.
      double w = 0.0, ss = 0.0;
      for (const auto& [dk, wk] : po) {
        w += wk;
        ss += wk * (dk - delta[r]) * (dk - delta[r]);
      }
      s2 = std::max(s2, ss / w / static_cast<double>(po.size() - 1));
    }
    sigma[r] = std::sqrt(s2);
  }
  double w = 0.0, wd = 0.0;
  for (size_t r = 0; r < rows; ++r) {
    if (!std::isfinite(sigma[r]) || sigma[r] <= 0.0) continue;
    ++out.rings;
    w += 1.0 / (sigma[r] * sigma[r]);
    wd += delta[r] / (sigma[r] * sigma[r]);
  }
  if (out.rings < kMinRingsMeasured) return out;
  out.measured = true;
  const double mean = wd / w;
  double ss = 0.0, chi2 = 0.0, worst = -1.0;
  for (size_t r = 0; r < rows; ++r) {
    if (!std::isfinite(sigma[r]) || sigma[r] <= 0.0) continue;
    const double e = delta[r] - mean, z = e / sigma[r];
    ss += e * e;
    chi2 += z * z;
    if (std::abs(z) > worst) {
      worst = std::abs(z);
      out.worst_ring = static_cast<int>(r);
      out.worst_deg = e * kRad2Deg;
      out.worst_sigma_deg = sigma[r] * kRad2Deg;
    }
  }
  out.rms_deg = std::sqrt(ss / out.rings) * kRad2Deg;
  out.chi2_per_ring = chi2 / out.rings;
  return out;
}

}  // namespace calibd
