#include "calibd/core/verdict/principal_point_check.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

namespace {

/// One observation's four corners: the board points, the detected corners undistorted through
/// the configured model (normalised), and there the pixel Jacobian of the distortion.
struct View {
  std::array<Eigen::Vector3d, 4> board;
  std::array<Eigen::Vector2d, 4> xy;
  std::array<Eigen::Matrix2d, 4> J;  // d pixel / d normalised point at xy
  std::array<double, 6> pose;        // angle-axis, translation: T_camera_board
};

/// Reprojection of one corner through its view's pose and the shared principal point shift, in
/// distorted pixels. A shift s moves the principal point, and with it the centre the lens
/// distorts about: pixel = f D(xy) + c + s. Undistorting the detection about the configured
/// centre instead and comparing there would take the distortion's change between the two centres
/// for part of the shift (with k1 = -0.12 a 8.5 px shift fitted as 6 px). To first order about
/// the detection's undistorted point xy0 (where f D(xy0) + c is the detected pixel), the residual
/// is J (xy - xy0) + s.
struct CornerResidual {
  CornerResidual(const Eigen::Vector3d& X, const Eigen::Vector2d& xy, const Eigen::Matrix2d& J)
      : X_(X), xy_(xy), J_(J) {}
  template <typename T>
  bool operator()(const T* pose, const T* shift, T* r) const {
    const T X[3] = {T(X_.x()), T(X_.y()), T(X_.z())};
    T p[3];
    ceres::AngleAxisRotatePoint(pose, X, p);
    for (int i = 0; i < 3; ++i) p[i] += pose[3 + i];
    const T dx = p[0] / p[2] - T(xy_.x()), dy = p[1] / p[2] - T(xy_.y());
    r[0] = T(J_(0, 0)) * dx + T(J_(0, 1)) * dy + shift[0];
    r[1] = T(J_(1, 0)) * dx + T(J_(1, 1)) * dy + shift[1];
    return true;
  }
  Eigen::Vector3d X_;
  Eigen::Vector2d xy_;
  Eigen::Matrix2d J_;
};

/// The shift fitted to views[i] for every i with use[i]; false when the solve failed. The views'
/// poses are left at the solution.
bool FitShift(std::vector<View>* views_io, const std::vector<char>& use, Eigen::Vector2d* shift) {
  std::vector<View>& views = *views_io;
  ceres::Problem problem;
  double s[2] = {shift->x(), shift->y()};
  ceres::ParameterBlockOrdering* ordering = new ceres::ParameterBlockOrdering;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!use[i]) continue;
    View& v = views[i];
    for (int c = 0; c < 4; ++c)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 6, 2>(
                                   new CornerResidual(v.board[c], v.xy[c], v.J[c])),
                               new ceres::HuberLoss(2.0), v.pose.data(), s);
    ordering->AddElementToGroup(v.pose.data(), 0);
  }
  ordering->AddElementToGroup(s, 1);
  ceres::Solver::Options options;
  // The poses are eliminated first: the reduced system is the 2 x 2 of the shift.
  options.linear_solver_type = ceres::DENSE_SCHUR;
  options.linear_solver_ordering.reset(ordering);
  options.max_num_iterations = 50;
  options.logging_type = ceres::SILENT;
  options.num_threads = 1;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  if (!summary.IsSolutionUsable() || !std::isfinite(s[0]) || !std::isfinite(s[1])) return false;
  *shift = Eigen::Vector2d(s[0], s[1]);
  return true;
}

/// The linearised response of the fitted shift at `shift` (views at the solution): with P_i the
/// 8 x 6 Jacobian of view i's residuals over its pose, M_i = I - P_i (P_i' P_i)^-1 P_i' leaves
/// what the pose cannot absorb, and S = [I I I I]' is the residuals' Jacobian over the shift.
/// Eliminating the poses (Schur complement), a change e_i of the detected corners moves the shift
/// by R^-1 sum_i S' M_i e_i with R = sum_i S' M_i S.
struct Sensitivity {
  /// For corner errors of kCornerNoisePx, independent from corner to corner.
  Eigen::Vector2d formal_px = Eigen::Vector2d::Zero();
  double residual_rms_px = 0.0;  ///< of the fit, per coordinate
  /// For a bias of kCornerBiasPx on one coordinate of one corner, the same in every view, each of
  /// the eight added in quadrature.
  Eigen::Vector2d systematic_px = Eigen::Vector2d::Zero();
};

Sensitivity ShiftSensitivity(const std::vector<View>& views, const Eigen::Vector2d& shift) {
  Eigen::Matrix2d R = Eigen::Matrix2d::Zero();
  Eigen::Matrix<double, 2, 8> Q = Eigen::Matrix<double, 2, 8>::Zero();
  double sum_squares = 0.0;
  Eigen::Matrix<double, 8, 2> S;
  for (int c = 0; c < 4; ++c) S.block<2, 2>(2 * c, 0).setIdentity();
  const double s[2] = {shift.x(), shift.y()};
  for (const View& v : views) {
    Eigen::Matrix<double, 8, 6> P;
    for (int c = 0; c < 4; ++c) {
      const ceres::AutoDiffCostFunction<CornerResidual, 2, 6, 2> cost(
          new CornerResidual(v.board[c], v.xy[c], v.J[c]));
      const double* parameters[2] = {v.pose.data(), s};
      double r[2];
      Eigen::Matrix<double, 2, 6, Eigen::RowMajor> J_pose;
      double* jacobians[2] = {J_pose.data(), nullptr};
      if (!cost.Evaluate(parameters, r, jacobians)) return {};
      P.block<2, 6>(2 * c, 0) = J_pose;
      sum_squares += r[0] * r[0] + r[1] * r[1];
    }
    const Eigen::Matrix<double, 8, 8> M = Eigen::Matrix<double, 8, 8>::Identity() -
                                          P * (P.transpose() * P).ldlt().solve(P.transpose());
    R += S.transpose() * M * S;
    Q += S.transpose() * M;
  }
  Sensitivity out;
  if (!(R.determinant() > 0.0)) return out;
  const Eigen::Matrix2d R_inv = R.inverse();
  // Residual RMS per coordinate: 8 per view, less the 6 pose and 2 shift parameters fitted.
  const double dof = static_cast<double>(8 * views.size() - 6 * views.size() - 2);
  const double rms = dof > 0.0 ? std::sqrt(sum_squares / dof) : 0.0;
  // Not the residuals' own RMS: a wrong lens model inflates it with its misfit, which the fit's
  // shift is no less sure of.
  out.formal_px = kCornerNoisePx * R_inv.diagonal().cwiseSqrt();
  out.residual_rms_px = rms;
  const Eigen::Matrix<double, 2, 8> response = R_inv * Q;
  out.systematic_px = kCornerBiasPx * response.rowwise().norm();
  return out;
}

}  // namespace

PrincipalPointEstimate EstimatePrincipalPoint(const CameraIntrinsics& camera,
                                              const std::vector<BoardGeometry>& boards,
                                              const SessionObservations& session) {
  PrincipalPointEstimate est;
  const CameraModel model(camera);
  const size_t n = session.camera.size();
  const size_t stride = (n + kMaxPrincipalPointObservations - 1) /
                        static_cast<size_t>(kMaxPrincipalPointObservations);
  std::vector<View> views;
  for (size_t i = 0; i < n; i += std::max<size_t>(1, stride)) {
    const SessionObservations::CameraBoard& b = session.camera[i];
    if (b.board_index < 0 || b.board_index >= static_cast<int>(boards.size())) continue;
    View v;
    v.board = boards[static_cast<size_t>(b.board_index)].TagCornersInBoard();
    bool ok = true;
    for (int c = 0; c < 4 && ok; ++c) {
      ok = model.Unproject(b.corners_px[c], &v.xy[c]);
      // Central differences of the forward model (a step of 1e-6 in normalised units, about a
      // thousandth of a pixel).
      constexpr double kStep = 1e-6;
      for (int a = 0; a < 2 && ok; ++a) {
        const Eigen::Vector2d e = Eigen::Vector2d::Unit(a) * kStep;
        v.J[c].col(a) =
            (model.DistortToPixel(v.xy[c] + e) - model.DistortToPixel(v.xy[c] - e)) / (2 * kStep);
      }
    }
    if (!ok) continue;
    const Eigen::AngleAxisd aa(b.T_camera_board.linear());
    const Eigen::Vector3d w = aa.angle() * aa.axis();
    const Eigen::Vector3d t = b.T_camera_board.translation();
    v.pose = {w.x(), w.y(), w.z(), t.x(), t.y(), t.z()};
    views.push_back(v);
  }
  est.observations = static_cast<int>(views.size());
  if (est.observations < kMinPrincipalPointObservations) return est;
  const std::vector<char> all(views.size(), 1);
  Eigen::Vector2d shift = Eigen::Vector2d::Zero();
  std::vector<View> solved = views;
  if (!FitShift(&solved, all, &shift)) return est;
  const Sensitivity sensitivity = ShiftSensitivity(solved, shift);
  // Delete-a-group jackknife: var = (G - 1) / G sum (theta_g - mean)^2.
  std::array<Eigen::Vector2d, kPrincipalPointGroups> left_out;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int g = 0; g < kPrincipalPointGroups; ++g) {
    std::vector<char> use(views.size(), 1);
    for (size_t i = 0; i < views.size(); ++i)
      if (static_cast<int>(i * kPrincipalPointGroups / views.size()) == g) use[i] = 0;
    left_out[static_cast<size_t>(g)] = shift;
    std::vector<View> subset = solved;
    if (!FitShift(&subset, use, &left_out[static_cast<size_t>(g)])) return est;
    mean += left_out[static_cast<size_t>(g)] / kPrincipalPointGroups;
  }
  Eigen::Vector2d var = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& s : left_out) var += (s - mean).cwiseAbs2();
  var *= static_cast<double>(kPrincipalPointGroups - 1) / kPrincipalPointGroups;
  est.fitted = true;
  est.shift_px = shift;
  // The corners' precision, independent from corner to corner (the fit's formal sigma), is the
  // floor of the jackknife's: consecutive groups of a drive repeat each other's geometry.
  est.sigma_px = var.cwiseSqrt().cwiseMax(sensitivity.formal_px);
  est.systematic_px = sensitivity.systematic_px;
  est.residual_rms_px = sensitivity.residual_rms_px;
  return est;
}

namespace {

// The tags' variance of the shift on axis a, with the blind spot when the corners are taken as
// biased; infinite when not fitted.
double TagsVariance(const PrincipalPointEstimate& tags, int a, CornerBias corners) {
  if (!tags.fitted) return std::numeric_limits<double>::infinity();
  const double blind_spot = corners == CornerBias::kAssumed ? tags.systematic_px(a) : 0.0;
  return tags.sigma_px(a) * tags.sigma_px(a) + blind_spot * blind_spot;
}

}  // namespace

PrincipalPointBelief CombinePrincipalPoint(const PrincipalPointEstimate& tags,
                                           double stated_sigma_px, CornerBias corners) {
  PrincipalPointBelief out;
  // A statement the tags refute, in this reading, no longer counts.
  const bool refuted = StatedPrincipalPointChiSquare(tags, stated_sigma_px, corners) >
                       kStatedPrincipalPointChiSquare;
  const double stated_var = stated_sigma_px > 0.0 && !refuted
                                ? stated_sigma_px * stated_sigma_px
                                : std::numeric_limits<double>::infinity();
  for (int a = 0; a < 2; ++a) {
    const double tags_var = TagsVariance(tags, a, corners);
    if (!std::isfinite(tags_var)) {
      out.sigma_px(a) = std::sqrt(stated_var);  // the prior alone (infinite when none)
      continue;
    }
    if (!std::isfinite(stated_var)) {
      out.shift_px(a) = tags.shift_px(a);
      out.sigma_px(a) = std::sqrt(tags_var);
      continue;
    }
    // The statement no sharper than the tags' own sigma could check (the blind spot is what no
    // session checks, not the tags' precision).
    const double checked_sigma = StatedSigmaAsChecked(stated_sigma_px, tags.sigma_px(a));
    const double checked_var = checked_sigma * checked_sigma;
    const double w = checked_var / (checked_var + tags_var);  // the tags' weight
    out.shift_px(a) = w * tags.shift_px(a);
    out.sigma_px(a) = std::sqrt(w * tags_var);
  }
  return out;
}

double StatedPrincipalPointChiSquare(const PrincipalPointEstimate& tags, double stated_sigma_px,
                                     CornerBias corners) {
  if (!tags.fitted || !(stated_sigma_px > 0.0)) return 0.0;
  double chi2 = 0.0;
  for (int a = 0; a < 2; ++a)
    chi2 += tags.shift_px(a) * tags.shift_px(a) /
            (TagsVariance(tags, a, corners) + stated_sigma_px * stated_sigma_px);
  return std::isfinite(chi2) ? chi2 : 0.0;
}

double PrincipalPointTurnDeg(const Eigen::Vector2d& shift_px, const CameraIntrinsics& camera) {
  return std::hypot(shift_px.x() / camera.fx, shift_px.y() / camera.fy) * kRad2Deg;
}

}  // namespace calibd
