#pragma once
/// \file
/// SE(3) parameter block for Ceres: ambient [t_x, t_y, t_z, q_x, q_y, q_z, q_w] (Eigen quaternion
/// order), tangent [dt, dtheta] with a left perturbation: t' = t + dt, R' = Exp(dtheta) R.
/// Cost functions over this block fill the first 6 columns of their Jacobian with the derivative
/// w.r.t. the tangent vector and 0 in the 7th; PlusJacobian is [I6; 0] so Ceres' product
/// J_ambient * PlusJacobian yields exactly that tangent Jacobian.

#include <ceres/manifold.h>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

class PoseManifold final : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

/// Packs a pose into the 7-vector, and back.
void PoseToParameters(const Pose& T, double* params);
Pose PoseFromParameters(const double* params);

}  // namespace calibd
