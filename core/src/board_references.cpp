#include "calibd/core/board_references.hpp"

#include <algorithm>
#include <cmath>
#include <random>

#include "calibd/core/geometry.hpp"

namespace calibd {

namespace {
constexpr double kDegToRad = M_PI / 180.0;

// Gap between the rings just below and just above `elevation_deg` (the outermost gap outside the
// table), degrees; 0 for fewer than two rings.
double RingGapAt(const std::vector<double>& rings_deg, double elevation_deg) {
  if (rings_deg.size() < 2) return 0.0;
  double below = -1e300, above = 1e300;
  for (double e : rings_deg) {
    if (e <= elevation_deg) below = std::max(below, e);
    if (e > elevation_deg) above = std::min(above, e);
  }
  if (below > -1e300 && above < 1e300) return above - below;
  std::vector<double> sorted = rings_deg;
  std::sort(sorted.begin(), sorted.end());
  return below > -1e300 ? sorted[sorted.size() - 1] - sorted[sorted.size() - 2]
                        : sorted[1] - sorted[0];
}
}  // namespace

void SimulateBoardCluster(const LidarModel& model, double width_m, double height_m,
                          const BoardView& view, std::vector<Eigen::Vector3f>* points,
                          std::vector<float>* weights) {
  points->clear();
  if (weights) weights->clear();
  const bool rings = model.has_rings && !model.ring_elevation_deg.empty();
  double elevation_deg = view.elevation_deg;
  if (rings)
    elevation_deg += view.elevation_phase * RingGapAt(model.ring_elevation_deg, view.elevation_deg);
  const double el0 = elevation_deg * kDegToRad;
  const Eigen::Vector3d dir(std::cos(el0), 0.0, std::sin(el0));
  const Eigen::Vector3d centre = view.distance_m * dir;
  // Board axes facing the sensor: normal -dir, x_B to the sensor's right as seen from the board
  // (-y), y_B up; then yaw about the vertical and pitch about the board's own x axis.
  Eigen::Matrix3d R_facing;
  R_facing.col(2) = -dir;
  R_facing.col(1) = Eigen::Vector3d(-std::sin(el0), 0.0, std::cos(el0));
  R_facing.col(0) = R_facing.col(1).cross(R_facing.col(2));
  const Eigen::Matrix3d R = RotationFromRpy(0.0, 0.0, view.yaw_deg * kDegToRad) * R_facing *
                            RotationFromRpy(view.pitch_deg * kDegToRad, 0.0, 0.0);
  const Eigen::Vector3d ax = R.col(0), ay = R.col(1), n = R.col(2);
  // Angular span to scan: the board's circumscribed sphere seen from the sensor.
  const double radius = 0.5 * std::hypot(width_m, height_m);
  const double half_span = std::asin(std::min(1.0, radius / view.distance_m)) + 1e-9;

  std::vector<double> elevations;
  if (rings) {
    for (double e : model.ring_elevation_deg) elevations.push_back(e * kDegToRad);
  } else {
    const double step = model.elevation_resolution_deg * kDegToRad;
    const int half_rows = static_cast<int>(std::ceil(half_span / step)) + 1;
    for (int j = -half_rows; j <= half_rows; ++j)
      elevations.push_back(el0 + (j + view.elevation_phase) * step);
  }
  const double az_step = model.azimuth_resolution_deg * kDegToRad;
  const int half_cols = static_cast<int>(std::ceil(half_span / az_step)) + 1;
  std::vector<double> sorted = elevations;
  std::sort(sorted.begin(), sorted.end());
  for (double el : elevations) {
    if (std::fabs(el - el0) > half_span) continue;
    // Elevation gap this row stands for: half the distance between its neighbouring rows.
    const auto it = std::lower_bound(sorted.begin(), sorted.end(), el);
    const double below = it != sorted.begin() ? el - *(it - 1) : -1.0;
    const double above = it + 1 != sorted.end() ? *(it + 1) - el : -1.0;
    const double gap = below > 0.0 && above > 0.0 ? 0.5 * (below + above) : std::max(below, above);
    const float weight = static_cast<float>(std::max(gap, 0.0));
    for (int k = -half_cols; k <= half_cols; ++k) {
      const double az = (k + view.azimuth_phase) * az_step;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      const double denom = d.dot(n);
      if (std::fabs(denom) < 1e-9) continue;
      const double t = centre.dot(n) / denom;
      if (t <= 0.0) continue;
      const Eigen::Vector3d local = t * d - centre;
      if (std::fabs(local.dot(ax)) <= 0.5 * width_m && std::fabs(local.dot(ay)) <= 0.5 * height_m) {
        points->push_back((t * d).cast<float>());
        if (weights) weights->push_back(weight);
      }
    }
  }
}

void AddRangeNoise(double sigma_m, uint64_t seed, std::vector<Eigen::Vector3f>* points) {
  if (!(sigma_m > 0.0)) return;
  std::mt19937_64 rng(seed);
  // Uniform in (0, 1]: 53 random bits.
  auto uniform = [&rng] { return (static_cast<double>(rng() >> 11) + 1.0) * 0x1.0p-53; };
  for (size_t i = 0; i < points->size(); i += 2) {
    // Box-Muller: two independent standard normals from two uniforms.
    const double r = std::sqrt(-2.0 * std::log(uniform())), a = 2.0 * M_PI * uniform();
    const double n[2] = {r * std::cos(a), r * std::sin(a)};
    for (size_t k = 0; k < 2 && i + k < points->size(); ++k) {
      Eigen::Vector3f& p = (*points)[i + k];
      const double range = p.norm();
      if (range > 0.0) p *= static_cast<float>((range + sigma_m * n[k]) / range);
    }
  }
}

std::vector<BoardView> DefaultReferenceViews() {
  std::vector<BoardView> views;
  for (double elevation : {0.0, -6.0})
    for (double distance : {5.0, 8.0, 12.0, 18.0, 25.0, 32.0})
      for (double yaw : {0.0, -20.0, 20.0, -40.0, 40.0})
        for (double pitch : {0.0, -20.0, 20.0, -40.0, 40.0})
          views.push_back(BoardView{distance, elevation, yaw, pitch});
  return views;
}

}  // namespace calibd
