#include <vector>

#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/verdict/measure_quality.hpp"

namespace calibd {

bool TimeOffsetShiftedSolve(const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                            const DirectResult& direct, const DirectOptimizerConfig& solver,
                            Pose* T_camera_lidar) {
  if (!direct.usable || !corr.motion_compensated || corr.observations.empty()) return false;
  const DirectOptimizerConfig one = ReSolveSettings(solver);
  ObservationSet shifted = corr;
  ShiftToCaptureTime(corr.time_offset_s + kTimeOffsetResponseStepS, direct.T_camera_lidar,
                     &shifted);
  const DirectResult moved = ResolveWithHeldBoards(boards, shifted, direct.T_camera_lidar, one,
                                                   HeldBoardPoses(corr, direct), nullptr);
  if (!moved.usable) return false;
  *T_camera_lidar = moved.T_camera_lidar;
  return true;
}

}  // namespace calibd
