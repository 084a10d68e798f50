#include "calibd/core/verdict/principal_point_check.hpp"

#include <Eigen/Geometry>

#include "calibd/core/camera/camera_pnp.hpp"

namespace calibd {

bool PrincipalPointShiftedBoards(const CameraIntrinsics& camera,
                                 const std::vector<BoardGeometry>& boards,
                                 const ObservationSet& corr, const std::vector<Pose>& held,
                                 std::array<std::vector<Pose>, 2>* moved) {
  const size_t n = corr.observations.size();
  if (n == 0 || held.size() != n) return false;
  const auto shifted = [&](int axis) {
    CameraIntrinsics intrinsics = camera;
    (axis == 0 ? intrinsics.cx : intrinsics.cy) += kPrincipalPointResponseStepPx;
    return CameraModel(intrinsics);
  };
  // Each observation's pose from its corners with the configured principal point, and with it
  // shifted along u and v: the held pose moves as the corners' pose does.
  const CameraModel models[3] = {CameraModel(camera), shifted(0), shifted(1)};
  for (auto& m : *moved) m.resize(n);
  for (size_t k = 0; k < n; ++k) {
    const BoardObservation& o = corr.observations[k];
    Pose poses[3];
    for (int m = 0; m < 3; ++m) {
      double rms = 0.0;
      if (!EstimateTagPose(models[m], boards[static_cast<size_t>(o.board_index)], o.corners_px,
                           &poses[m], &rms))
        return false;
    }
    const Pose to_held = poses[0].inverse() * held[k];
    (*moved)[0][k] = poses[1] * to_held;
    (*moved)[1][k] = poses[2] * to_held;
  }
  return true;
}

}  // namespace calibd
