#include "calibd/core/board_references.hpp"

#include <cmath>

#include "calibd/core/geometry.hpp"

namespace calibd {

namespace {
constexpr double kDegToRad = M_PI / 180.0;
}  // namespace

void SimulateBoardCluster(const LidarModel& model, double width_m, double height_m,
                          const BoardView& view, std::vector<Eigen::Vector3f>* points) {
  points->clear();
  const double el0 = view.elevation_deg * kDegToRad;
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
  if (model.has_rings && !model.ring_elevation_deg.empty()) {
    for (double e : model.ring_elevation_deg) elevations.push_back(e * kDegToRad);
  } else {
    const double step = model.elevation_resolution_deg * kDegToRad;
    for (double e = el0 - half_span; e <= el0 + half_span; e += step) elevations.push_back(e);
  }
  const double az_step = model.azimuth_resolution_deg * kDegToRad;
  const int half_cols = static_cast<int>(std::ceil(half_span / az_step)) + 1;
  for (double el : elevations) {
    if (std::fabs(el - el0) > half_span) continue;
    for (int k = -half_cols; k <= half_cols; ++k) {
      const double az = k * az_step;
      const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                              std::sin(el));
      const double denom = d.dot(n);
      if (std::fabs(denom) < 1e-9) continue;
      const double t = centre.dot(n) / denom;
      if (t <= 0.0) continue;
      const Eigen::Vector3d local = t * d - centre;
      if (std::fabs(local.dot(ax)) <= 0.5 * width_m && std::fabs(local.dot(ay)) <= 0.5 * height_m)
        points->push_back((t * d).cast<float>());
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
