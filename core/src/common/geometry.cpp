#include "calibd/core/common/geometry.hpp"

#include <algorithm>
#include <cmath>

namespace calibd {

Eigen::Matrix3d RotationFromRpy(double roll, double pitch, double yaw) {
  return (Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(pitch, Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d RpyFromRotation(const Eigen::Matrix3d& R) {
  // Row 2 of R is (-sin p, cos p sin r, cos p cos r): roll from it, then M = R Rx(roll)^T =
  // Rz(yaw) Ry(pitch) = [[cy cp, -sy, cy sp], [sy cp, cy, sy sp], [-sp, 0, cp]] gives yaw and
  // pitch from entries that stay of unit size. Reading yaw from R(1,0), R(0,0) instead (both
  // cos(pitch) times something) fails at pitch = +-90 deg, where a forward camera's
  // T_camera_lidar sits: atan2(0, 0) returned roll = yaw = 0, a different rotation. Here any roll
  // there is absorbed into yaw, and the angles rebuild R to rounding everywhere.
  const double roll = std::atan2(R(2, 1), R(2, 2));
  const Eigen::Matrix3d M =
      R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitX()).toRotationMatrix().transpose();
  const double yaw = std::atan2(-M(0, 1), M(1, 1));
  const double pitch = std::atan2(-M(2, 0), M(2, 2));  // M(2,2) = hypot(R(2,1), R(2,2)) >= 0
  return {roll, pitch, yaw};
}

Pose PoseFromXyzRpy(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy) {
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(rpy.x(), rpy.y(), rpy.z());
  T.translation() = xyz;
  return T;
}

double RotationAngle(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b) {
  const Eigen::Matrix3d R = R_a.transpose() * R_b;
  // acos of the trace is inaccurate near 0; atan2 of |axis*sin| and cos is not.
  const double c = std::clamp((R.trace() - 1.0) / 2.0, -1.0, 1.0);
  const Eigen::Vector3d w(R(2, 1) - R(1, 2), R(0, 2) - R(2, 0), R(1, 0) - R(0, 1));
  return std::atan2(0.5 * w.norm(), c);
}

Eigen::Matrix3d RotationFromAxisAngle(const Eigen::Vector3d& axis, double angle) {
  return Eigen::AngleAxisd(angle, axis.normalized()).toRotationMatrix();
}

Eigen::Matrix<double, 6, 1> PoseTangent(const Pose& from, const Pose& to) {
  Eigen::Matrix<double, 6, 1> d;
  d.head<3>() = to.translation() - from.translation();
  const Eigen::AngleAxisd turn(to.linear() * from.linear().transpose());
  d.tail<3>() = turn.angle() * turn.axis();
  return d;
}

Pose PoseMovedBy(const Pose& from, const Eigen::Matrix<double, 6, 1>& d) {
  Pose to = from;
  to.translation() += d.head<3>();
  const double angle = d.tail<3>().norm();
  if (angle > 0.0) to.linear() = RotationFromAxisAngle(d.tail<3>() / angle, angle) * from.linear();
  return to;
}

}  // namespace calibd
