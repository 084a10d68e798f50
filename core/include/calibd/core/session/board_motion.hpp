#pragma once
/// \file
/// Motion compensation of LiDAR board points (beyond the paper, which assumes a static scene per
/// frame pair). While the vehicle drives, a sweep's points fire over 0.05-0.1 s and the camera
/// exposes at one instant: a MEMS sensor sweeping top to bottom (Falcon, M1) shears a board by
/// centimetres at 3 m/s, and every sensor shifts boards that it crosses away from the camera's
/// capture time. Each point is moved to the camera's capture time with the board's own apparent
/// velocity in the camera frame, measured by the camera from the same board in neighbouring
/// frames. Being relative, it needs no odometry and also covers boards carried past a parked
/// car. Across one board the velocity field of a rigid motion varies by |omega| x 0.3 m: 13 mm/s
/// at a 2.5 deg/s yaw rate, under 1 mm over a 0.05 s sweep, so one velocity per board is enough.

#include <Eigen/Core>
#include <limits>
#include <string>
#include <vector>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/session/board_observation.hpp"
#include "calibd/core/session/session_observations.hpp"

namespace calibd {

struct MotionCompensationConfig {
  bool enabled = true;
  /// Camera detections of the same board within this time of a frame's capture enter its
  /// velocity fit (+-0.25 s: up to 5 frames at 10 Hz). Longer smooths PnP noise of far boards,
  /// shorter follows braking better; frames recorded further apart than it while driving need
  /// it longer (engine.motion_window_s), or their boards have no velocity.
  /// It is not widened by itself when frames lie further apart: a few frames seconds apart
  /// cannot tell a board moving steadily from one carried between still poses (a velocity
  /// fitted across poses shears still boards by centimetres), so the recording's owner says so.
  double window_s = 0.25;
  int min_samples = 3;  ///< detections in the window, the frame's own included
  /// The samples' times must span at least this share of window_s (0.15 s of +-0.25 s).
  double min_span_share = 0.6;
  double max_speed_mps = 20.0;  ///< a faster apparent board speed is a mismatch: not used
  /// When the boards move by more than this between a frame's sensor times (median over the
  /// observations with a velocity of |u| times their points' mean |dt|), an observation whose
  /// velocity could not be measured (its board in too few of the camera's neighbouring frames)
  /// is dropped: its points lie where the board was when the LiDAR fired, up to that far from
  /// where the camera saw it, and a few of them bias the translation by centimetres.
  double max_unmeasured_shift_m = 0.003;

  bool IsValid(std::string* error) const;
};

inline constexpr double kMaxMotionWindowS = 2.0;  ///< the longest window_s

/// Least-squares line c(t) = c0 + u (t - t_frame) through the board centres (camera frame) of
/// `board_index` in the other frames whose capture time lies within the window of `frame`'s: not
/// the frame's own, whose PnP noise would otherwise enter both its velocity and its distance,
/// and turn a still board's noise into a time offset (errors in the regressor: still poses read
/// 0.2-0.3 s at 3-4 sigma). The frame's own detection counts towards min_samples and its time
/// towards the span. False (and
/// `velocity` untouched) when the frame times are unknown or the samples are too few, too short
/// in time or too fast.
bool EstimateBoardVelocity(const SessionObservations& session, int frame, int board_index,
                           const MotionCompensationConfig& config, Eigen::Vector3d* velocity);

struct MotionCompensationStats {
  int compensated = 0;    ///< observations whose points were moved
  int uncompensated = 0;  ///< observations left as they were (no velocity estimate)
  /// Observations without a velocity dropped because the boards moved (max_unmeasured_shift_m).
  int dropped = 0;
  double max_shift_m = 0.0;
  double median_shift_m = 0.0;    ///< over the compensated observations
  double window_s = 0.0;          ///< the velocity fit's window, +-s
  double frame_interval_s = 0.0;  ///< MedianFrameInterval of the session
  /// No board's motion could be measured because the frames lie further apart than the window:
  /// if the boards moved (driving, carried), engine.motion_window_s should be about 1.5 times
  /// frame_interval_s.
  bool FramesBeyondWindow() const {
    return compensated == 0 && uncompensated > 0 && frame_interval_s > window_s;
  }
};

/// The median time between consecutive frames' camera captures (s); 0 when the times are
/// unknown.
double MedianFrameInterval(const SessionObservations& session);

/// Estimates each observation's board velocity and moves its points to the camera's capture
/// time: p <- p - dt R_camera_lidar^T u (dt = firing time - capture time, u in the camera frame;
/// the rotation of the coarse extrinsic is precise enough for a shift of a few cm), then drops the
/// observations without a velocity when the others moved (max_unmeasured_shift_m). Does nothing
/// when disabled or when `set` is already compensated.
MotionCompensationStats CompensateBoardMotion(const SessionObservations& session,
                                              const Pose& T_camera_lidar,
                                              const MotionCompensationConfig& config,
                                              ObservationSet* set);

/// The camera's time offset against the LiDAR, estimated from the boards' motion
/// (the spatiotemporal idea of Furgale et al., "Unified temporal and spatial calibration for
/// multi-sensor systems", IROS 2013, reduced to one parameter). A camera that exposes `offset_s`
/// later than its stamps say saw each board where it was `offset_s` later: the compensated
/// points lie short of the camera's board by offset_s u (u its velocity). Along the board's
/// normal n that is offset_s (n . u), which a translation cannot take up once the boards move
/// towards and away from the camera (n . u of both signs). Per observation, with
/// d = n . (camera board centre) - median over its points of n . (T_camera_lidar p):
///   d = n . c + offset_s (n . u)     (c: what a translation explains)
/// fitted by least squares, each row weighted by the inverse of PnP's distance error (which grows
/// with the distance over the tag's size in pixels). The sigma is the larger of the least-squares
/// one and a cluster-robust one over blocks of kTimeOffsetBlockFrames frames of a board
/// (consecutive frames of a board share their errors). Observations without a velocity enter with n
/// . u = 0.
struct TimeOffsetEstimate {
  bool fitted = false;  ///< enough observations with a velocity, and the fit determined
  double offset_s = 0.0;
  double sigma_s = std::numeric_limits<double>::infinity();
  /// RMS of n . u over the observations with a velocity (m/s): how fast the boards move along
  /// their normals. sigma_s times it is the translation an offset as large as its sigma moves.
  double normal_speed_rms_mps = 0.0;
  int observations = 0;  ///< with a velocity
};

inline constexpr int kTimeOffsetBlockFrames = 10;
/// Observations with a velocity the fit needs (and at least this many blocks of them).
inline constexpr int kMinTimeOffsetObservations = 12;

/// Whether fits of `distances` carry the residual time offset's term tau (n . v): a compensated
/// set with kMinTimeOffsetObservations rows with a velocity or more.
bool HasTimeOffsetTerm(const ObservationSet& set, const std::vector<BoardDistance>& distances);

TimeOffsetEstimate EstimateTimeOffset(const ObservationSet& set, const Pose& T_camera_lidar);
/// The same from the set's BoardDistances under the solution, computed once for the checks that
/// share them.
TimeOffsetEstimate EstimateTimeOffset(const ObservationSet& set,
                                      const std::vector<BoardDistance>& distances);

/// Moves the compensated points of every observation with a velocity to the capture time of a
/// camera whose offset is `offset_s` (set->time_offset_s becomes it): p += (offset_s -
/// set->time_offset_s) R_camera_lidar^T u. Does nothing before CompensateBoardMotion.
void ShiftToCaptureTime(double offset_s, const Pose& T_camera_lidar, ObservationSet* set);

}  // namespace calibd
