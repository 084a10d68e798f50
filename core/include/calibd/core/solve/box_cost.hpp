#pragma once
/// \file
/// The box cost of one board observation for the direct optimisation (paper Eq. 3 and 5), as a
/// Ceres cost function over T_camera_lidar (a PoseManifold parameter block).
///
/// For each LiDAR point p of the board, p_B = T_board_camera * T_camera_lidar * p, and per axis
/// c(lambda, a) = |lambda| - a when |lambda| > a, else 0 (paper Eq. 1: for a >= 0 this equals
/// min{|lambda - a|, |lambda + a|}), with a = width/2, height/2 and alpha on x, y, z.
///
/// Handling the non-smooth cost: the paper sums c (an L1-like, kinked function). We minimise the
/// sum of squared signed hinges r = sign(lambda) c(lambda, a), which is continuously
/// differentiable (the kink at |lambda| = a has zero slope once squared), so Gauss-Newton/LM
/// apply; a Huber loss on each point's residual norm bounds the pull of mis-associated points.
/// The loss is applied inside the functor, per point (a Ceres LossFunction would act on the whole
/// observation's residual block): the residual is sqrt(rho(|r|^2)) r/|r| with its exact Jacobian.

#include <ceres/cost_function.h>

#include <Eigen/Core>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

class BoardBoxCost final : public ceres::CostFunction {
 public:
  /// `points` (LiDAR frame, m) must outlive the cost. `stride` > 1 uses every stride-th point.
  /// `huber_m` is the Huber threshold on a point's residual norm (<= 0: plain least squares).
  BoardBoxCost(const Eigen::Vector3f* points, int num_points, int stride,
               const Pose& T_board_camera, double half_width, double half_height, double alpha,
               double huber_m);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// Per-point residual for a given T_camera_lidar, without the robust loss (for statistics).
  Eigen::Vector3d PointResidual(const Pose& T_camera_lidar, int i) const;
  int num_used_points() const { return num_used_; }

 private:
  const Eigen::Vector3f* points_;
  int num_used_, stride_;
  Eigen::Matrix3d R_board_camera_;
  Eigen::Vector3d t_board_camera_;
  Eigen::Vector3d half_extent_;  ///< (width/2, height/2, alpha)
  double huber_;
};

}  // namespace calibd
