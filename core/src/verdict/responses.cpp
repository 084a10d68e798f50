#include <vector>

#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/verdict/measure_quality.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"

namespace calibd {

Responses MeasureResponses(const CameraIntrinsics& camera, const std::vector<BoardGeometry>& boards,
                           const ObservationSet& corr, const DirectResult& direct,
                           const DirectOptimizerConfig& solver) {
  Responses out;
  if (!direct.usable || corr.observations.empty()) return out;
  const DirectOptimizerConfig one = ReSolveSettings(solver);
  const std::vector<Pose> held = HeldBoardPoses(corr, direct);
  // Every solve from the unmoved one's end: a shifted one then has only its response to go.
  Pose unmoved, moved;
  if (!SolveHeldBoardsByGaussNewton(boards, corr, direct.T_camera_lidar, one, held, &unmoved))
    return out;
  const auto response = [&](const ObservationSet& set, const std::vector<Pose>& boards_held,
                            double step, auto column) {
    if (!SolveHeldBoardsByGaussNewton(boards, set, unmoved, one, boards_held, &moved)) return false;
    column = PoseTangent(unmoved, moved) / step;
    return true;
  };
  std::array<std::vector<Pose>, 2> shifted_boards;
  out.principal_point = PrincipalPointShiftedBoards(camera, boards, corr, held, &shifted_boards) &&
                        response(corr, shifted_boards[0], kPrincipalPointResponseStepPx,
                                 out.per_principal_point_px.col(0)) &&
                        response(corr, shifted_boards[1], kPrincipalPointResponseStepPx,
                                 out.per_principal_point_px.col(1));
  std::vector<Pose> farther = held;
  for (Pose& T : farther) T.translation() *= 1.0 + kCameraScaleResponseStep;
  out.camera_scale = response(corr, farther, kCameraScaleResponseStep, out.per_camera_scale.col(0));
  if (corr.motion_compensated) {
    ObservationSet later = corr;
    ShiftToCaptureTime(corr.time_offset_s + kTimeOffsetResponseStepS, direct.T_camera_lidar,
                       &later);
    out.time_offset = response(later, held, kTimeOffsetResponseStepS, out.per_time_offset_s.col(0));
  }
  return out;
}

}  // namespace calibd
