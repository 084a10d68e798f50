#pragma once
/// \file
/// Why a calibration session ended without a trusted new calibration: the one list of reason
/// codes. The engine's refusals, the session machine's failures and aborts, the agent's log and
/// CALIBD_RESULT, report.json, the UDS results record (its byte is the code: ISO 14229-1
/// routineStatusRecord of agent/uds/routines.hpp) and calibd-tester all take their names and
/// codes from here; the operator guide's troubleshooting table explains each one.

#include <cstdint>
#include <ostream>
#include <string_view>

namespace calibd {

enum class Reason : uint8_t {
  kNone = 0x00,
  kStopped = 0x01,                 ///< a stop request (UDS stopRoutine, the LCM command)
  kSessionEnded = 0x02,            ///< S3 timeout or a change to the default session
  kTooFewFrames = 0x03,            ///< fewer frame pairs than min_frames when the session ended
  kTooFewBoards = 0x04,            ///< fewer board correspondences than needed
  kNoCameraBoards = 0x05,          ///< the camera saw no configured board
  kNoLidarBoards = 0x06,           ///< the LiDAR found no board cluster
  kNoGridCandidate = 0x07,         ///< no extrinsic in the grid search's range aligns the boards
  kSolverFailed = 0x08,            ///< the optimiser did not converge
  kPoorObservability = 0x09,       ///< a formal sigma above its gate: boards too few or too alike
  kUnstableSolution = 0x0A,        ///< re-solves on halves of the data or from other starts move it
  kHighReprojectionError = 0x0B,   ///< LiDAR-fitted tag corners miss the camera's (paper Table I)
  kHighResidual = 0x0C,            ///< LiDAR board points lie far from their boards
  kDeltaBeyondTolerance = 0x0D,    ///< the change from the prior exceeds the mechanical tolerance
  kInvalidConfig = 0x0E,           ///< a setting is out of range (the detail names it)
  kCommitFailed = 0x0F,            ///< a commit or restore could not write the store
  kInterlockReleased = 0x10,       ///< the GPIO interlock was released during the session
  kEcuReset = 0x11,                ///< an ECU reset during the session
  kLidarTimeout = 0x12,            ///< no LiDAR frame for sensor_timeout_s
  kCameraTimeout = 0x13,           ///< no camera frame for sensor_timeout_s
  kNoPairs = 0x14,                 ///< both sensors send, but no frames pair in time
  kCameraScaleMismatch = 0x15,     ///< camera and LiDAR board distances differ in proportion
  kLidarRangeOffset = 0x16,        ///< the LiDAR's ranges are offset by a constant
  kTimeOffset = 0x17,              ///< the camera's time offset is beyond the engine's tolerance
  kPrincipalPointMismatch = 0x18,  ///< the tags' principal point would turn the result
  kLidarModelMismatch = 0x19,      ///< the clouds fall outside the model's field of view
  kBoardIdsSwapped = 0x1A,         ///< two boards of different sizes have each other's ids
  kBoardNotFlat = 0x1B,            ///< a board's points bend away from its tag's plane
  kLidarRingElevation = 0x1C,      ///< the lasers disagree with the model's elevation table
  kOther = 0xFF,                   ///< not a known reason (a newer agent's); the log has its text
};

struct ReasonName {
  Reason reason;
  std::string_view name;
};

/// Every reason but kNone with its name, in code order.
inline constexpr ReasonName kReasonNames[] = {
    {Reason::kStopped, "stopped"},
    {Reason::kSessionEnded, "session_ended"},
    {Reason::kTooFewFrames, "too_few_frames"},
    {Reason::kTooFewBoards, "too_few_boards"},
    {Reason::kNoCameraBoards, "no_camera_boards"},
    {Reason::kNoLidarBoards, "no_lidar_boards"},
    {Reason::kNoGridCandidate, "no_grid_candidate"},
    {Reason::kSolverFailed, "solver_failed"},
    {Reason::kPoorObservability, "poor_observability"},
    {Reason::kUnstableSolution, "unstable_solution"},
    {Reason::kHighReprojectionError, "high_reprojection_error"},
    {Reason::kHighResidual, "high_residual"},
    {Reason::kDeltaBeyondTolerance, "delta_beyond_tolerance"},
    {Reason::kInvalidConfig, "invalid_config"},
    {Reason::kCommitFailed, "commit_failed"},
    {Reason::kInterlockReleased, "interlock_released"},
    {Reason::kEcuReset, "ecu_reset"},
    {Reason::kLidarTimeout, "lidar_timeout"},
    {Reason::kCameraTimeout, "camera_timeout"},
    {Reason::kNoPairs, "no_pairs"},
    {Reason::kCameraScaleMismatch, "camera_scale_mismatch"},
    {Reason::kLidarRangeOffset, "lidar_range_offset"},
    {Reason::kTimeOffset, "time_offset_beyond_tolerance"},
    {Reason::kPrincipalPointMismatch, "principal_point_mismatch"},
    {Reason::kLidarModelMismatch, "lidar_model_mismatch"},
    {Reason::kBoardIdsSwapped, "board_ids_swapped"},
    {Reason::kBoardNotFlat, "board_not_flat"},
    {Reason::kLidarRingElevation, "lidar_ring_elevation"},
    {Reason::kOther, "other"},
};

/// The reason's name ("too_few_frames"), a string literal (data() is null-terminated); "" for
/// kNone, "other" for a code not in the table.
constexpr std::string_view NameOf(Reason reason) {
  for (const ReasonName& r : kReasonNames)
    if (r.reason == reason) return r.name;
  return reason == Reason::kNone ? std::string_view("") : std::string_view("other");
}

/// The reason of a name: kNone for "", kOther for a name not in the table.
constexpr Reason ReasonFromName(std::string_view name) {
  if (name.empty()) return Reason::kNone;
  for (const ReasonName& r : kReasonNames)
    if (r.name == name) return r.reason;
  return Reason::kOther;
}

/// The reason of a results record's byte: kOther for a byte not in the table.
constexpr Reason ReasonFromCode(uint8_t code) {
  if (code == 0) return Reason::kNone;
  for (const ReasonName& r : kReasonNames)
    if (static_cast<uint8_t>(r.reason) == code) return r.reason;
  return Reason::kOther;
}

/// For test failures and logs: the name.
inline std::ostream& operator<<(std::ostream& os, Reason reason) {
  return os << (reason == Reason::kNone ? std::string_view("none") : NameOf(reason));
}

}  // namespace calibd
