#include <vector>

#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/verdict/measure_quality.hpp"

namespace calibd {

bool TimeOffsetResponse(const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                        const DirectResult& direct, const DirectOptimizerConfig& solver,
                        Eigen::Matrix<double, 6, 1>* response) {
  if (!direct.usable || !corr.motion_compensated || corr.observations.empty()) return false;
  DirectOptimizerConfig one = solver;
  one.threads = 1;
  const size_t n = corr.observations.size();
  std::vector<Pose> held(n);
  for (size_t k = 0; k < n; ++k)
    held[k] = direct.T_camera_board.size() == n ? direct.T_camera_board[k]
                                                : corr.observations[k].T_camera_board;
  const DirectResult unmoved =
      ResolveWithHeldBoards(boards, corr, direct.T_camera_lidar, one, held, nullptr);
  ObservationSet shifted = corr;
  ShiftToCaptureTime(corr.time_offset_s + kTimeOffsetResponseStepS, direct.T_camera_lidar,
                     &shifted);
  const DirectResult moved =
      ResolveWithHeldBoards(boards, shifted, direct.T_camera_lidar, one, held, nullptr);
  if (!unmoved.usable || !moved.usable) return false;
  *response = PoseTangent(unmoved.T_camera_lidar, moved.T_camera_lidar) / kTimeOffsetResponseStepS;
  return true;
}

}  // namespace calibd
