#include "calibd/core/solve/board_pose_refinement.hpp"

#include <ceres/tiny_solver.h>

#include <cmath>
#include <vector>

#include "calibd/core/solve/pose_manifold.hpp"
#include "solve/box_hinge.hpp"

namespace calibd {

namespace {

// A residual far beyond any board's: where a cost cannot be evaluated (a corner behind the
// camera), so that TinySolver, which does not look at a trial step's return value, rejects it.
constexpr double kUnusable = 1e10;

// The terms' residuals at a perturbation `delta` = [dt, dtheta] of the start pose (PoseManifold's
// Plus) and, when asked, their Jacobian in delta (column-major, NumResiduals() x 6): the costs'
// own tangent-space Jacobians at the perturbed pose, which is the exact one at delta = 0 and
// leaves the minimum where it is elsewhere (TinySolver's model).
class BoardPoseResiduals {
 public:
  using Scalar = double;
  enum { NUM_RESIDUALS = Eigen::Dynamic, NUM_PARAMETERS = 6 };

  BoardPoseResiduals(const BoardPoseTerms& terms, const double* start)
      : terms_(terms),
        start_(start),
        box_rows_(terms.box->num_residuals()),
        box_jacobian_(static_cast<size_t>(box_rows_) * 7) {}

  int NumResiduals() const { return box_rows_ + 2 * terms_.num_corners; }

  bool operator()(const double* delta, double* residuals, double* jacobian) const {
    double b[7];
    PoseManifold().Plus(start_, delta, b);
    if (!Evaluate(b, residuals, jacobian)) {
      for (int r = 0; r < NumResiduals(); ++r) residuals[r] = kUnusable;
      return false;
    }
    return true;
  }

 private:
  bool Evaluate(const double* b, double* residuals, double* jacobian) const {
    const int rows = NumResiduals();
    const double* box_parameters[2] = {terms_.T_camera_lidar, b};
    double* box_jacobians[2] = {nullptr, box_jacobian_.data()};
    if (!terms_.box->Evaluate(box_parameters, residuals,
                              jacobian != nullptr ? box_jacobians : nullptr))
      return false;
    // The costs' Jacobians are row-major over 7 columns, the seventh zero (PoseManifold's
    // tangent layout); TinySolver's is column-major.
    if (jacobian != nullptr)
      for (int r = 0; r < box_rows_; ++r)
        for (int c = 0; c < 6; ++c) jacobian[c * rows + r] = box_jacobian_[7 * r + c];
    const double* corner_parameters[1] = {b};
    for (int k = 0; k < terms_.num_corners; ++k) {
      Eigen::Vector2d f;
      Eigen::Matrix<double, 2, 7, Eigen::RowMajor> J;
      double* corner_jacobians[1] = {J.data()};
      if (!terms_.corners[k]->Evaluate(corner_parameters, f.data(),
                                       jacobian != nullptr ? corner_jacobians : nullptr))
        return false;
      // The Huber loss on the corner's residual norm, as box_hinge.hpp applies it.
      double along = 1.0, across = 1.0;
      const double n = f.norm();
      detail::HuberScales(n, terms_.corner_huber, &along, &across);
      const int row = box_rows_ + 2 * k;
      residuals[row] = across * f.x();
      residuals[row + 1] = across * f.y();
      if (jacobian == nullptr) continue;
      const Eigen::Vector2d u = n > 0.0 ? Eigen::Vector2d(f / n) : Eigen::Vector2d::Zero();
      const Eigen::Matrix2d robust =
          along * u * u.transpose() + across * (Eigen::Matrix2d::Identity() - u * u.transpose());
      const Eigen::Matrix<double, 2, 6> Jr = robust * J.leftCols<6>();
      for (int c = 0; c < 6; ++c) {
        jacobian[c * rows + row] = Jr(0, c);
        jacobian[c * rows + row + 1] = Jr(1, c);
      }
    }
    return true;
  }

  const BoardPoseTerms& terms_;
  const double* start_;
  int box_rows_;
  mutable std::vector<double> box_jacobian_;
};

}  // namespace

bool RefineBoardPose(const BoardPoseTerms& terms, int max_iterations, double function_tolerance,
                     Pose* T_camera_board) {
  double start[7];
  PoseToParameters(*T_camera_board, start);
  const BoardPoseResiduals residuals(terms, start);
  Eigen::VectorXd f(residuals.NumResiduals());
  Eigen::Matrix<double, 6, 1> delta = Eigen::Matrix<double, 6, 1>::Zero();
  if (!residuals(delta.data(), f.data(), nullptr)) return false;
  ceres::TinySolver<BoardPoseResiduals> solver;
  solver.options.max_num_iterations = max_iterations;
  // TinySolver ends on an absolute change of twice the cost: relative to the start's.
  solver.options.function_tolerance = function_tolerance * f.squaredNorm();
  solver.options.gradient_tolerance = 1e-12;
  solver.options.parameter_tolerance = 1e-12;
  const auto& summary = solver.Solve(residuals, &delta);
  if (!delta.allFinite() || !(summary.final_cost <= summary.initial_cost)) return false;
  double refined[7];
  PoseManifold().Plus(start, delta.data(), refined);
  *T_camera_board = PoseFromParameters(refined);
  return true;
}

}  // namespace calibd
