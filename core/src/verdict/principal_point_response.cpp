#include "calibd/core/verdict/principal_point_check.hpp"

#include <Eigen/Geometry>

#include "calibd/core/camera/camera_pnp.hpp"

namespace calibd {

namespace {

// The extrinsic re-solved from `direct`'s with every observation's held board pose
// (HeldBoardPoses) moved as its PnP pose moves, from `before` (the configured principal point's),
// when the principal point is shifted by `shift_px`.
bool ResolveShifted(const CameraIntrinsics& camera, const std::vector<BoardGeometry>& boards,
                    const ObservationSet& corr, const DirectResult& direct,
                    const DirectOptimizerConfig& one, const std::vector<Pose>& before,
                    const Eigen::Vector2d& shift_px, Pose* T_camera_lidar) {
  CameraIntrinsics moved_intrinsics = camera;
  moved_intrinsics.cx += shift_px.x();
  moved_intrinsics.cy += shift_px.y();
  const CameraModel moved(moved_intrinsics);
  std::vector<Pose> held = HeldBoardPoses(corr, direct);
  for (size_t k = 0; k < held.size(); ++k) {
    const BoardObservation& o = corr.observations[k];
    Pose after;
    double rms = 0.0;
    if (!EstimateTagPose(moved, boards[static_cast<size_t>(o.board_index)], o.corners_px, &after,
                         &rms))
      return false;
    held[k] = after * before[k].inverse() * held[k];
  }
  const DirectResult r =
      ResolveWithHeldBoards(boards, corr, direct.T_camera_lidar, one, held, nullptr);
  if (!r.usable) return false;
  *T_camera_lidar = r.T_camera_lidar;
  return true;
}

}  // namespace

bool PrincipalPointShiftedSolve(const CameraIntrinsics& camera,
                                const std::vector<BoardGeometry>& boards,
                                const ObservationSet& corr, const DirectResult& direct,
                                const DirectOptimizerConfig& solver, int axis,
                                Pose* T_camera_lidar) {
  if (!direct.usable || corr.observations.empty()) return false;
  const DirectOptimizerConfig one = ReSolveSettings(solver);
  // Each observation's pose from its corners with the configured principal point, which the
  // shifted pose is taken against.
  const CameraModel configured(camera);
  std::vector<Pose> before(corr.observations.size());
  for (size_t k = 0; k < before.size(); ++k) {
    const BoardObservation& o = corr.observations[k];
    double rms = 0.0;
    if (!EstimateTagPose(configured, boards[static_cast<size_t>(o.board_index)], o.corners_px,
                         &before[k], &rms))
      return false;
  }
  const Eigen::Vector2d step = Eigen::Vector2d::Unit(axis) * kPrincipalPointResponseStepPx;
  return ResolveShifted(camera, boards, corr, direct, one, before, step, T_camera_lidar);
}

}  // namespace calibd
