#include "calibd/core/solve/corner_reprojection_cost.hpp"

#include <Eigen/Geometry>

#include "solve/box_hinge.hpp"

namespace calibd {

CornerReprojectionCost::CornerReprojectionCost(const Eigen::Vector3d& corner_board,
                                               const Eigen::Vector2d& observed_normalized,
                                               double scale)
    : corner_(corner_board), observed_(observed_normalized), scale_(scale) {}

bool CornerReprojectionCost::Evaluate(double const* const* parameters, double* residuals,
                                      double** jacobians) const {
  const double* b = parameters[0];
  const Eigen::Matrix3d R =
      Eigen::Quaterniond(b[6], b[3], b[4], b[5]).normalized().toRotationMatrix();
  const Eigen::Vector3d rotated = R * corner_;
  const Eigen::Vector3d X = rotated + Eigen::Vector3d(b[0], b[1], b[2]);
  if (!(X.z() > 1e-6)) return false;  // behind the camera: Ceres rejects the step
  const double inv_z = 1.0 / X.z();
  residuals[0] = scale_ * (X.x() * inv_z - observed_.x());
  residuals[1] = scale_ * (X.y() * inv_z - observed_.y());
  if (jacobians == nullptr || jacobians[0] == nullptr) return true;
  Eigen::Matrix<double, 2, 3> d_proj;
  d_proj << inv_z, 0.0, -X.x() * inv_z * inv_z, 0.0, inv_z, -X.y() * inv_z * inv_z;
  d_proj *= scale_;
  // Left perturbation: t' = t + dt, R' = Exp(dtheta) R gives dX = dt - [R c]x dtheta.
  Eigen::Map<Eigen::Matrix<double, 2, 7, Eigen::RowMajor>> J(jacobians[0]);
  J.leftCols<3>() = d_proj;
  J.middleCols<3>(3) = -d_proj * detail::Skew(rotated);
  J.col(6).setZero();
  return true;
}

}  // namespace calibd
