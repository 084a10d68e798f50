#pragma once
/// \file
/// The box cost (paper Eq. 3-5, BoardBoxCost's residuals) of many board observations, handed to
/// Ceres as its Gauss-Newton normal equations instead of one row per point.
///
/// T_camera_lidar has 6 degrees of freedom, but a session has ~150k board points, i.e. a
/// 450k x 7 Jacobian that Ceres writes, checks, scales and multiplies at every iteration (half
/// the direct solve's time went there, not into the cost). This cost accumulates, per point,
/// H = J^T J and g = J^T r of BoardBoxCost's three rows (6 x 6 and 6 x 1, tangent space) and
/// returns 7 residuals e with a 7 x 7 Jacobian J_e such that J_e^T J_e = H, J_e^T e = g and
/// |e|^2 = r^T r: with H = V diag(l) V^T, row i of J_e is sqrt(l_i) v_i^T and e_i = v_i^T g /
/// sqrt(l_i) (0 where l_i ~ 0, where g has no component either), and a seventh residual with a
/// zero Jacobian carries the rest of the cost. Ceres' linearised model 1/2 |e + J_e d|^2 is then
/// exactly 1/2 |r + J d|^2, its Jacobi scaling (the column norms, diag H) and LM damping are the
/// same, so the solver takes the same steps as with the full Jacobian, up to rounding. Where
/// Ceres asks for the cost alone, e = (|r|, 0, ..., 0).
///
/// The quality figures (information, plane information, residual RMS without the loss) come
/// from Statistics() over the same rows.

#include <ceres/cost_function.h>

#include <Eigen/Core>
#include <vector>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

/// One board observation's points in the compressed cost.
struct BoxTerm {
  const Eigen::Vector3f* points = nullptr;  ///< LiDAR frame, m; must outlive the cost
  int num_points = 0;
  int stride = 1;  ///< every stride-th point is used
  Pose T_board_camera = Pose::Identity();
  Eigen::Vector3d half_extent = Eigen::Vector3d::Zero();  ///< (width/2, height/2, alpha)

  int num_used() const { return stride > 1 ? (num_points + stride - 1) / stride : num_points; }
};

/// J^T J of the points' rows at a pose (tangent space [dt, dtheta], left perturbation), of the
/// board-plane rows alone (the z term of Eq. 3), and the sum of the squared residuals without
/// the robust loss.
struct BoxStatistics {
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Zero();
  Eigen::Matrix<double, 6, 6> plane_information = Eigen::Matrix<double, 6, 6>::Zero();
  double sum_squared_residuals = 0.0;
  int points = 0;
  /// J^T r of each term's points (the robust residuals the solve minimises), one entry per term
  /// in the order of the terms: what clustered_covariance.hpp clusters.
  std::vector<Eigen::Matrix<double, 6, 1>> term_scores;
};

class CompressedBoxCost final : public ceres::CostFunction {
 public:
  static constexpr int kResiduals = 7;

  /// `huber_m`: Huber threshold on a point's residual norm, as BoardBoxCost's (<= 0: none).
  CompressedBoxCost(std::vector<BoxTerm> terms, double huber_m);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  /// H = J^T J, g = J^T r and r^T r of BoardBoxCost's rows at T_camera_lidar = `x` (7
  /// parameters, PoseToParameters).
  void NormalEquations(const double* x, Eigen::Matrix<double, 6, 6>* H,
                       Eigen::Matrix<double, 6, 1>* g, double* rtr) const;

  /// r^T r (with the robust loss) at T_camera_lidar = `x`: what Ceres asks for to judge a step.
  double Cost(const double* x) const;

  /// Accumulates the quality figures of every term's points at `T_camera_lidar` into `stats`.
  void Statistics(const Pose& T_camera_lidar, BoxStatistics* stats) const;

  int num_used_points() const { return num_used_; }

 private:
  std::vector<BoxTerm> terms_;
  double huber_;
  int num_used_ = 0;
};

}  // namespace calibd
