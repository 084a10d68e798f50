#pragma once
/// \file
/// Rigid-transform helpers. Transforms are named by frames: T_a_b maps a point from frame b into
/// frame a (p_a = T_a_b * p_b).

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cmath>

namespace calibd {

using Pose = Eigen::Isometry3d;

/// Degrees in a radian and radians in a degree: the one definition of each.
inline constexpr double kRad2Deg = 180.0 / M_PI;
inline constexpr double kDeg2Rad = M_PI / 180.0;

/// Rotation from roll (about x), pitch (about y), yaw (about z), radians: R = Rz(yaw) Ry(pitch)
/// Rx(roll).
Eigen::Matrix3d RotationFromRpy(double roll, double pitch, double yaw);

/// Inverse of RotationFromRpy, radians, pitch in [-pi/2, pi/2]: RotationFromRpy of the result
/// rebuilds R to rounding, at pitch = +-90 deg too (there only yaw -+ roll is defined; roll comes
/// from R's last row). Ill-conditioned near pitch = +-90 deg (docs/conventions.md#euler): compare
/// rotations with RotationAngle, never with Euler differences.
Eigen::Vector3d RpyFromRotation(const Eigen::Matrix3d& R);

/// Pose from translation (m) and roll/pitch/yaw (radians).
Pose PoseFromXyzRpy(const Eigen::Vector3d& xyz, const Eigen::Vector3d& rpy);

/// Angle of R_a^T R_b in radians: the rotation error between two estimates.
double RotationAngle(const Eigen::Matrix3d& R_a, const Eigen::Matrix3d& R_b);

/// The tangent [dt (m), dtheta (rad)] from `from` to `to` (left perturbation: to = exp(dtheta)
/// from, translations subtracted): how far a re-solve moved a result.
Eigen::Matrix<double, 6, 1> PoseTangent(const Pose& from, const Pose& to);

/// `from` moved by the tangent `d` [dt (m), dtheta (rad)] (left perturbation): PoseTangent's
/// inverse, and PoseManifold's Plus.
Pose PoseMovedBy(const Pose& from, const Eigen::Matrix<double, 6, 1>& d);

/// Rotation of `angle` radians about the unit `axis`.
Eigen::Matrix3d RotationFromAxisAngle(const Eigen::Vector3d& axis, double angle);

}  // namespace calibd
