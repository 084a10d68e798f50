#include "calibd/agent/uds/routines.hpp"

namespace calibd::uds {

RoutineReason RoutineReasonCode(std::string_view reason) {
  using R = RoutineReason;
  static constexpr struct {
    std::string_view text;
    R code;
  } kCodes[] = {{"stopped", R::kStopped},
                {"session_ended", R::kSessionEnded},
                {"too_few_frames", R::kTooFewFrames},
                {"too_few_boards", R::kTooFewBoards},
                {"no_camera_boards", R::kNoCameraBoards},
                {"no_lidar_boards", R::kNoLidarBoards},
                {"no_grid_candidate", R::kNoGridCandidate},
                {"solver_failed", R::kSolverFailed},
                {"poor_observability", R::kPoorObservability},
                {"unstable_solution", R::kUnstableSolution},
                {"high_reprojection_error", R::kHighReprojectionError},
                {"high_residual", R::kHighResidual},
                {"delta_beyond_tolerance", R::kDeltaBeyondTolerance},
                {"invalid_config", R::kInvalidConfig},
                {"commit_failed", R::kStoreWriteFailed},
                {"interlock_released", R::kInterlockReleased},
                {"ecu_reset", R::kEcuReset},
                {"lidar_timeout", R::kLidarTimeout},
                {"camera_timeout", R::kCameraTimeout},
                {"no_pairs", R::kNoPairs},
                {"camera_scale_mismatch", R::kCameraScaleMismatch},
                {"lidar_range_offset", R::kLidarRangeOffset},
                {"time_offset_beyond_tolerance", R::kTimeOffset},
                {"principal_point_mismatch", R::kPrincipalPointMismatch},
                {"lidar_model_mismatch", R::kLidarModelMismatch},
                {"board_ids_swapped", R::kBoardIdsSwapped},
                {"board_not_flat", R::kBoardNotFlat},
                {"lidar_ring_elevation", R::kLidarRingElevation}};
  if (reason.empty()) return R::kNone;
  for (const auto& c : kCodes)
    if (reason == c.text) return c.code;
  return R::kOther;
}

}  // namespace calibd::uds
