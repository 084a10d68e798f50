#include "calibd/core/verdict/principal_point_check.hpp"

#include <Eigen/Geometry>

#include "calibd/core/camera/camera_pnp.hpp"

namespace calibd {

namespace {

// The extrinsic re-solved from `direct`'s with every observation's held board pose moved as its
// PnP pose moves, from `before` (the configured principal point's), when the principal point is
// shifted by `shift_px`; `before` empty: the poses unmoved.
bool ResolveShifted(const CameraIntrinsics& camera, const std::vector<BoardGeometry>& boards,
                    const ObservationSet& corr, const DirectResult& direct,
                    const DirectOptimizerConfig& one, const std::vector<Pose>& before,
                    const Eigen::Vector2d& shift_px, Pose* T_camera_lidar) {
  CameraIntrinsics moved_intrinsics = camera;
  moved_intrinsics.cx += shift_px.x();
  moved_intrinsics.cy += shift_px.y();
  const CameraModel moved(moved_intrinsics);
  const size_t n = corr.observations.size();
  const bool refined = direct.T_camera_board.size() == n;
  std::vector<Pose> held(n);
  for (size_t k = 0; k < n; ++k) {
    const BoardObservation& o = corr.observations[k];
    const Pose& solved = refined ? direct.T_camera_board[k] : o.T_camera_board;
    held[k] = solved;
    if (before.empty()) continue;
    Pose after;
    double rms = 0.0;
    if (!EstimateTagPose(moved, boards[static_cast<size_t>(o.board_index)], o.corners_px, &after,
                         &rms))
      return false;
    held[k] = after * before[k].inverse() * solved;
  }
  const DirectResult r =
      ResolveWithHeldBoards(boards, corr, direct.T_camera_lidar, one, held, nullptr);
  if (!r.usable) return false;
  *T_camera_lidar = r.T_camera_lidar;
  return true;
}

}  // namespace

bool PrincipalPointResponse(const CameraIntrinsics& camera,
                            const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                            const DirectResult& direct, const DirectOptimizerConfig& solver,
                            Eigen::Matrix<double, 6, 2>* response) {
  if (!direct.usable || corr.observations.empty()) return false;
  DirectOptimizerConfig one = solver;
  one.threads = 1;
  Pose unmoved;
  if (!ResolveShifted(camera, boards, corr, direct, one, {}, Eigen::Vector2d::Zero(), &unmoved))
    return false;
  // Each observation's pose from its corners with the configured principal point, which both
  // shifted poses are taken against.
  const CameraModel configured(camera);
  std::vector<Pose> before(corr.observations.size());
  for (size_t k = 0; k < before.size(); ++k) {
    const BoardObservation& o = corr.observations[k];
    double rms = 0.0;
    if (!EstimateTagPose(configured, boards[static_cast<size_t>(o.board_index)], o.corners_px,
                         &before[k], &rms))
      return false;
  }
  for (int a = 0; a < 2; ++a) {
    Pose shifted;
    const Eigen::Vector2d step = Eigen::Vector2d::Unit(a) * kPrincipalPointResponseStepPx;
    if (!ResolveShifted(camera, boards, corr, direct, one, before, step, &shifted)) return false;
    response->col(a) = PoseTangent(unmoved, shifted) / kPrincipalPointResponseStepPx;
  }
  return true;
}

}  // namespace calibd
