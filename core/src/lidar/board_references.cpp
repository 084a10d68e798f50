#include "calibd/core/lidar/board_references.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <random>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

namespace {

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
Eigen::Vector3d Direction(double elevation_rad, double azimuth_rad) {
  return {std::cos(elevation_rad) * std::cos(azimuth_rad),
          std::cos(elevation_rad) * std::sin(azimuth_rad), std::sin(elevation_rad)};
}

// Uniform in (0, 1] from 53 random bits (our own transform, so that the result does not depend
// on the standard library's distributions).
double Uniform(std::mt19937_64* rng) {
  return (static_cast<double>((*rng)() >> 11) + 1.0) * 0x1.0p-53;
}

// A seed from every field of the view (their bits, mixed as splitmix64 does).
uint64_t SeedOf(const BoardView& view) {
  uint64_t seed = 0;
  for (double v : {view.distance_m, view.elevation_deg, view.yaw_deg, view.pitch_deg,
                   view.azimuth_phase, view.elevation_phase}) {
    uint64_t bits;
    std::memcpy(&bits, &v, sizeof bits);
    seed += bits + 0x9e3779b97f4a7c15ULL;
    seed = (seed ^ (seed >> 30)) * 0xbf58476d1ce4e5b9ULL;
    seed = (seed ^ (seed >> 27)) * 0x94d049bb133111ebULL;
    seed ^= seed >> 31;
  }
  return seed;
}

// A non-repetitive pattern's frame over the board: beams uniform in solid angle over the patch
// el0 +- half_span (and the azimuths it spans), as many as the pattern's density
// (nominal_points_per_frame over its field of view) gives; then, as LidarDetector describes a
// real cluster, one mean point per range-image cell hit. The view's phases shift the cells and
// seed the draw, so each phase is another frame.
template <typename Hit>
void SampleIrregularBeams(const LidarModel& model, double el0, double half_span,
                          const BoardView& view, const Hit& hit,
                          std::vector<Eigen::Vector3f>* points, std::vector<float>* weights) {
  const double az_fov = (model.azimuth_max_deg - model.azimuth_min_deg) * kDeg2Rad;
  const double el_lo_fov = model.elevation_min_deg * kDeg2Rad;
  const double el_hi_fov = model.elevation_max_deg * kDeg2Rad;
  const double fov_sr = az_fov * (std::sin(el_hi_fov) - std::sin(el_lo_fov));
  const int frame_points = model.pattern_points_per_frame > 0 ? model.pattern_points_per_frame
                                                              : model.nominal_points_per_frame;
  if (!(fov_sr > 0.0) || frame_points <= 0) return;
  const double per_sr = frame_points / fov_sr;
  const double el_lo = el0 - half_span, el_hi = el0 + half_span;
  const double half_az = std::min(M_PI, half_span / std::max(0.05, std::cos(el0)));
  const double patch_sr = 2.0 * half_az * (std::sin(el_hi) - std::sin(el_lo));
  const long beams = std::lround(per_sr * patch_sr);
  std::mt19937_64 rng(SeedOf(view));
  const double az_step = model.azimuth_resolution_deg * kDeg2Rad;
  const double el_step = model.elevation_resolution_deg * kDeg2Rad;
  struct Cell {
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int hits = 0;
  };
  std::map<std::pair<long, long>, Cell> cells;
  for (long b = 0; b < beams; ++b) {
    const double az = (2.0 * Uniform(&rng) - 1.0) * half_az;
    const double el =
        std::asin(std::sin(el_lo) + Uniform(&rng) * (std::sin(el_hi) - std::sin(el_lo)));
    Eigen::Vector3d p;
    if (!hit(Direction(el, az), &p)) continue;
    Cell& c = cells[{std::lround(std::floor(az / az_step + view.azimuth_phase)),
                     std::lround(std::floor(el / el_step + view.elevation_phase))}];
    c.sum += p;
    ++c.hits;
  }
  for (const auto& [key, c] : cells) {
    const Eigen::Vector3d mean = c.sum / c.hits;
    points->push_back(mean.cast<float>());
    if (weights) weights->push_back(static_cast<float>(el_step));
  }
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
  const double el0 = elevation_deg * kDeg2Rad;
  const Eigen::Vector3d dir(std::cos(el0), 0.0, std::sin(el0));
  const Eigen::Vector3d centre = view.distance_m * dir;
  // Board axes facing the sensor: normal -dir, x_B to the sensor's right as seen from the board
  // (-y), y_B up; then yaw about the vertical and pitch about the board's own x axis.
  Eigen::Matrix3d R_facing;
  R_facing.col(2) = -dir;
  R_facing.col(1) = Eigen::Vector3d(-std::sin(el0), 0.0, std::cos(el0));
  R_facing.col(0) = R_facing.col(1).cross(R_facing.col(2));
  const Eigen::Matrix3d R = RotationFromRpy(0.0, 0.0, view.yaw_deg * kDeg2Rad) * R_facing *
                            RotationFromRpy(view.pitch_deg * kDeg2Rad, 0.0, 0.0);
  const Eigen::Vector3d ax = R.col(0), ay = R.col(1), n = R.col(2);
  // Angular span to scan: the board's circumscribed sphere seen from the sensor.
  const double radius = 0.5 * std::hypot(width_m, height_m);
  const double half_span = std::asin(std::min(1.0, radius / view.distance_m)) + 1e-9;

  // Where the beam of direction `d` hits the board, if it does.
  auto hit = [&](const Eigen::Vector3d& d, Eigen::Vector3d* p) {
    const double denom = d.dot(n);
    if (std::fabs(denom) < 1e-9) return false;
    const double t = centre.dot(n) / denom;
    if (t <= 0.0) return false;
    const Eigen::Vector3d local = t * d - centre;
    *p = t * d;
    return std::fabs(local.dot(ax)) <= 0.5 * width_m && std::fabs(local.dot(ay)) <= 0.5 * height_m;
  };
  if (model.non_repetitive) {
    SampleIrregularBeams(model, el0, half_span, view, hit, points, weights);
    return;
  }

  std::vector<double> elevations;
  if (rings) {
    for (double e : model.ring_elevation_deg) elevations.push_back(e * kDeg2Rad);
  } else {
    const double step = model.elevation_resolution_deg * kDeg2Rad;
    const int half_rows = static_cast<int>(std::ceil(half_span / step)) + 1;
    for (int j = -half_rows; j <= half_rows; ++j)
      elevations.push_back(el0 + (j + view.elevation_phase) * step);
  }
  const double az_step = model.azimuth_resolution_deg * kDeg2Rad;
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
      Eigen::Vector3d p;
      if (hit(Direction(el, az), &p)) {
        points->push_back(p.cast<float>());
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
    for (double distance : {2.0, 3.5, 5.0, 8.0, 12.0, 18.0, 25.0, 32.0})
      for (double yaw : {0.0, -20.0, 20.0, -40.0, 40.0})
        for (double pitch : {0.0, -20.0, 20.0, -40.0, 40.0})
          views.push_back(BoardView{distance, elevation, yaw, pitch});
  return views;
}

}  // namespace calibd
