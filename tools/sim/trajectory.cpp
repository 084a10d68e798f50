#include "trajectory.hpp"

#include <cmath>

#include "calibd/core/common/validation.hpp"

namespace calibd::sim {

bool TrajectoryOptions::IsValid(std::string* error) const {
  if (mode != "drive" && mode != "static" && mode != "close" && mode != "far" && mode != "stills")
    return Invalid(error,
                   "--trajectory must be drive, static, close, far or stills (got '" + mode + "')");
  if (!(min_distance_m >= 1.0 && max_distance_m > min_distance_m && max_distance_m <= 150.0))
    return Invalid(error, "--distance must satisfy 1 <= min < max <= 150 m");
  if (!(static_distance_m >= 1.0 && static_distance_m <= 150.0))
    return Invalid(error, "--static-distance must be in [1, 150] m");
  if (!(duration_s > 0.0 && duration_s <= 3600.0))
    return Invalid(error, "--duration must be in (0, 3600] s");
  if (!(rate_hz > 0.0 && rate_hz <= 50.0)) return Invalid(error, "--rate must be in (0, 50] Hz");
  return true;
}

int TrajectoryOptions::num_frames() const {
  return static_cast<int>(std::floor(duration_s * rate_hz + 1e-9));
}

Pose VehiclePoseAt(const TrajectoryOptions& o, double lidar_x_m, double t) {
  double near = o.min_distance_m, far = o.max_distance_m;
  if (o.mode == "close") {
    near = 6.0;
    far = 8.5;
  } else if (o.mode == "far") {
    near = 25.0;
    far = 30.0;
  }
  double distance = o.static_distance_m, lateral = 0.0, yaw = 0.0;
  if (o.mode != "static" && o.mode != "stills") {
    // One smooth out-and-back: starts and ends at the near distance, at rest.
    const double phase = 2.0 * M_PI * t / o.duration_s;
    distance = near + (far - near) * 0.5 * (1.0 - std::cos(phase));
    lateral = o.weave_m * std::sin(1.5 * phase);
    yaw = o.yaw_weave_deg * M_PI / 180.0 * std::sin(2.5 * phase);
  }
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(0.0, 0.0, yaw);
  T.translation() = Eigen::Vector3d(-distance - lidar_x_m, lateral, 0.0);
  return T;
}

}  // namespace calibd::sim
