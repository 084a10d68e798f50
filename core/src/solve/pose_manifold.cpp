#include "calibd/core/solve/pose_manifold.hpp"

#include <Eigen/Geometry>

namespace calibd {

namespace {
Eigen::Quaterniond ExpQuaternion(const Eigen::Vector3d& w) {
  const double angle = w.norm();
  if (angle < 1e-12)
    return Eigen::Quaterniond(1.0, 0.5 * w.x(), 0.5 * w.y(), 0.5 * w.z()).normalized();
  return Eigen::Quaterniond(Eigen::AngleAxisd(angle, w / angle));
}
}  // namespace

void PoseToParameters(const Pose& T, double* p) {
  const Eigen::Quaterniond q(T.linear());
  p[0] = T.translation().x();
  p[1] = T.translation().y();
  p[2] = T.translation().z();
  p[3] = q.x();
  p[4] = q.y();
  p[5] = q.z();
  p[6] = q.w();
}

Pose PoseFromParameters(const double* p) {
  Pose T = Pose::Identity();
  T.linear() = Eigen::Quaterniond(p[6], p[3], p[4], p[5]).normalized().toRotationMatrix();
  T.translation() = Eigen::Vector3d(p[0], p[1], p[2]);
  return T;
}

bool PoseManifold::Plus(const double* x, const double* delta, double* out) const {
  const Eigen::Quaterniond q(x[6], x[3], x[4], x[5]);
  const Eigen::Quaterniond q_new =
      (ExpQuaternion(Eigen::Vector3d(delta[3], delta[4], delta[5])) * q).normalized();
  for (int i = 0; i < 3; ++i) out[i] = x[i] + delta[i];
  out[3] = q_new.x();
  out[4] = q_new.y();
  out[5] = q_new.z();
  out[6] = q_new.w();
  return true;
}

bool PoseManifold::PlusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 7, 6, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.topRows<6>().setIdentity();
  return true;
}

bool PoseManifold::Minus(const double* y, const double* x, double* out) const {
  const Eigen::Quaterniond qy(y[6], y[3], y[4], y[5]), qx(x[6], x[3], x[4], x[5]);
  const Eigen::AngleAxisd aa(qy * qx.conjugate());
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  for (int i = 0; i < 3; ++i) {
    out[i] = y[i] - x[i];
    out[3 + i] = w[i];
  }
  return true;
}

bool PoseManifold::MinusJacobian(const double*, double* jacobian) const {
  Eigen::Map<Eigen::Matrix<double, 6, 7, Eigen::RowMajor>> J(jacobian);
  J.setZero();
  J.leftCols<6>().setIdentity();
  return true;
}

}  // namespace calibd
