#include "calibd/core/principal_point_check.hpp"

#include <ceres/ceres.h>
#include <ceres/rotation.h>

#include <Eigen/Geometry>
#include <array>
#include <cmath>

namespace calibd {

namespace {

/// One observation's four corners: the ideal pinhole pixels (undistorted, configured K) of the
/// board points.
struct View {
  std::array<Eigen::Vector3d, 4> board;
  std::array<Eigen::Vector2d, 4> px;
  std::array<double, 6> pose;  // angle-axis, translation: T_camera_board
};

/// Reprojection of one corner through its view's pose and the shared principal point shift.
struct CornerResidual {
  CornerResidual(const Eigen::Vector3d& X, const Eigen::Vector2d& px, const CameraIntrinsics& k)
      : X_(X), px_(px), fx_(k.fx), fy_(k.fy), cx_(k.cx), cy_(k.cy) {}
  template <typename T>
  bool operator()(const T* pose, const T* shift, T* r) const {
    const T X[3] = {T(X_.x()), T(X_.y()), T(X_.z())};
    T p[3];
    ceres::AngleAxisRotatePoint(pose, X, p);
    for (int i = 0; i < 3; ++i) p[i] += pose[3 + i];
    r[0] = T(fx_) * p[0] / p[2] + T(cx_) + shift[0] - T(px_.x());
    r[1] = T(fy_) * p[1] / p[2] + T(cy_) + shift[1] - T(px_.y());
    return true;
  }
  Eigen::Vector3d X_;
  Eigen::Vector2d px_;
  double fx_, fy_, cx_, cy_;
};

/// The shift fitted to views[i] for every i with use[i]; false when the solve failed.
bool FitShift(const CameraIntrinsics& k, std::vector<View> views, const std::vector<char>& use,
              Eigen::Vector2d* shift) {
  ceres::Problem problem;
  double s[2] = {shift->x(), shift->y()};
  ceres::ParameterBlockOrdering* ordering = new ceres::ParameterBlockOrdering;
  for (size_t i = 0; i < views.size(); ++i) {
    if (!use[i]) continue;
    View& v = views[i];
    for (int c = 0; c < 4; ++c)
      problem.AddResidualBlock(new ceres::AutoDiffCostFunction<CornerResidual, 2, 6, 2>(
                                   new CornerResidual(v.board[c], v.px[c], k)),
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
      Eigen::Vector2d xy;
      ok = model.Unproject(b.corners_px[c], &xy);
      v.px[c] = Eigen::Vector2d(camera.fx * xy.x() + camera.cx, camera.fy * xy.y() + camera.cy);
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
  if (!FitShift(camera, views, all, &shift)) return est;
  // Delete-a-group jackknife: var = (G - 1) / G sum (theta_g - mean)^2.
  std::array<Eigen::Vector2d, kPrincipalPointGroups> left_out;
  Eigen::Vector2d mean = Eigen::Vector2d::Zero();
  for (int g = 0; g < kPrincipalPointGroups; ++g) {
    std::vector<char> use(views.size(), 1);
    for (size_t i = 0; i < views.size(); ++i)
      if (static_cast<int>(i * kPrincipalPointGroups / views.size()) == g) use[i] = 0;
    left_out[static_cast<size_t>(g)] = shift;
    if (!FitShift(camera, views, use, &left_out[static_cast<size_t>(g)])) return est;
    mean += left_out[static_cast<size_t>(g)] / kPrincipalPointGroups;
  }
  Eigen::Vector2d var = Eigen::Vector2d::Zero();
  for (const Eigen::Vector2d& s : left_out) var += (s - mean).cwiseAbs2();
  var *= static_cast<double>(kPrincipalPointGroups - 1) / kPrincipalPointGroups;
  est.fitted = true;
  est.shift_px = shift;
  est.sigma_px = var.cwiseSqrt();
  return est;
}

}  // namespace calibd
