#include "calibd/core/verdict/range_offset.hpp"

#include <algorithm>
#include <array>
#include <cmath>

#include "calibd/core/common/stats.hpp"

namespace calibd {
namespace {

// Unknowns: the camera's scale, a translation (3), a rotation (3), the range offset, and the
// residual time offset when timed.
constexpr int kScale = 0, kTranslation = 1, kRotation = 4, kOffset = 7;
// Reweighting passes: the first unweighted, each next with the kinds' scatter from the last.
constexpr int kPasses = 4;
// Kinds of row: along the board's x, along its y, along its normal.
constexpr int kKinds = 3;
// A kind's scatter is never taken below this (a perfect simulation would divide by zero).
constexpr double kMinScatterM = 1e-4;

struct Row {
  const BoardObservation* observation;
  Eigen::VectorXd a;
  double y;
  int kind;
};

// camera - LiDAR along the unit axis e (camera frame) of observation o is
//   s (e . c) + e . t + (c x e) . w + b (-e . u) + tau (e . v)
// for a board centre c, the rays' mean u and velocity v; the signs of t and w are the fit's own.
std::vector<Row> RangeOffsetRows(const std::vector<BoardDistance>& distances, bool timed) {
  const int k = timed ? kOffset + 2 : kOffset + 1;
  std::vector<Row> rows;
  rows.reserve(distances.size() * kKinds);
  for (const BoardDistance& d : distances) {
    const BoardObservation& o = *d.observation;
    const Eigen::Vector3d c = o.T_camera_board.translation();
    for (int kind = 0; kind < kKinds; ++kind) {
      const bool normal = kind == 2;
      const Eigen::Vector3d e =
          normal ? d.normal : Eigen::Vector3d(o.T_camera_board.linear().col(kind));
      Row r{&o, Eigen::VectorXd(k), normal ? d.camera_m - d.lidar_m : -d.lidar_in_plane(kind),
            kind};
      r.a(kScale) = e.dot(c);
      r.a.segment<3>(kTranslation) = e;
      r.a.segment<3>(kRotation) = c.cross(e);
      r.a(kOffset) = -e.dot(normal ? d.mean_ray : d.mean_ray_area);
      if (timed) r.a(kOffset + 1) = o.has_velocity ? e.dot(o.velocity) : 0.0;
      rows.push_back(std::move(r));
    }
  }
  return rows;
}

}  // namespace

RangeOffsetFit FitRangeOffset(const std::vector<BoardDistance>& distances, bool timed,
                              int min_cluster_blocks) {
  RangeOffsetFit out;
  const std::vector<Row> rows = RangeOffsetRows(distances, timed);
  if (rows.empty()) return out;
  const int k = static_cast<int>(rows[0].a.size());
  std::array<double, kKinds> scatter;
  scatter.fill(1.0);
  DistanceFit fit;
  std::vector<double> residuals;
  for (int pass = 0; pass < kPasses; ++pass) {
    DistanceFitter fitter(k);
    for (const Row& r : rows) {
      const double s = scatter[static_cast<size_t>(r.kind)];
      if (pass > 0 && std::fabs(r.y - r.a.dot(fit.x)) > kRangeOffsetOutlierSigmas * s) continue;
      fitter.Add(*r.observation, r.a / s, r.y / s);
    }
    const DistanceFit next = fitter.Fit();
    if (!next.fitted) return out;
    fit = next;
    // Median absolute residual of each kind, scaled to a normal sigma.
    constexpr double kMadToSigma = 1.4826;
    for (int kind = 0; kind < kKinds; ++kind) {
      residuals.clear();
      for (const Row& r : rows)
        if (r.kind == kind) residuals.push_back(std::fabs(r.y - r.a.dot(fit.x)));
      scatter[static_cast<size_t>(kind)] =
          std::max(kMinScatterM, kMadToSigma * Quantile(residuals, 0.5));
    }
  }
  out.fitted = true;
  out.offset_m = fit.x(kOffset);
  out.sigma_m = fit.Sigma(kOffset, min_cluster_blocks);
  out.blocks = fit.blocks;
  return out;
}

}  // namespace calibd
