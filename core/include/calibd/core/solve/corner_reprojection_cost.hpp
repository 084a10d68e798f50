#pragma once
/// \file
/// The camera's evidence of a board pose: one tag corner's reprojection error, as a Ceres cost
/// over T_camera_board (PoseManifold). The detected corner is undistorted once to normalised
/// coordinates, so the residual is (X/Z - x_n, Y/Z - y_n) * scale: with scale = fx it is close to
/// the pixel error (exact for an undistorted camera; distortion changes its local scale by the
/// distortion's derivative, a few percent), and the caller folds the noise weighting into scale.

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

namespace calibd {

class CornerReprojectionCost final : public ceres::SizedCostFunction<2, 7> {
 public:
  /// `corner_board`: the corner in the board frame (m); `observed_normalized`: the detection,
  /// undistorted to normalised image coordinates.
  CornerReprojectionCost(const Eigen::Vector3d& corner_board,
                         const Eigen::Vector2d& observed_normalized, double scale);

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  Eigen::Vector3d corner_;
  Eigen::Vector2d observed_;
  double scale_;
};

}  // namespace calibd
