#include "verdict_gates.hpp"

#include <cmath>

#include "calibd/core/text_format.hpp"

namespace calibd::detail {

Reason FailedGate(const CameraIntrinsics& camera, const VerdictConfig& v,
                  const CalibrationOutcome& out, std::string* detail) {
  const QualityFigures& q = out.quality;
  auto refuse = [detail](Reason reason, std::string text) {
    *detail = std::move(text);
    return reason;
  };
  // A bent board first: it also shows as a range offset, a scale, a lens misfit or scatter.
  if (std::fabs(q.board_bend_m) > kMaxBoardBendM &&
      std::fabs(q.board_bend_m) > kBoardBendSigmas * q.board_bend_sigma_m)
    return refuse(Reason::kBoardNotFlat,
                  "board " + std::to_string(q.board_bend_id) + "'s face bends " +
                      FixedDecimal(std::fabs(q.board_bend_m) * 1e3, 1) + " mm (+-" +
                      FixedDecimal(q.board_bend_sigma_m * 1e3, 1) + ") " +
                      (q.board_bend_m > 0.0 ? "towards" : "away from") +
                      " the sensors at its centre line, more than " +
                      FixedDecimal(kMaxBoardBendM * 1e3, 1) +
                      " mm: the LiDAR sees it off the plane of its tag; flatten or replace the "
                      "board (the operator guide asks for 2 mm under a straight edge)");
  if (q.plane_conditioning < v.min_plane_conditioning)
    return refuse(Reason::kPoorObservability,
                  "the board planes leave a direction unconstrained (conditioning " +
                      FixedDecimal(q.plane_conditioning, 6) + " below " +
                      FixedDecimal(v.min_plane_conditioning, 6) +
                      "): boards too few or all parallel");
  if (q.rotation_sigma_deg > v.max_rotation_sigma_deg ||
      q.translation_sigma_m > v.max_translation_sigma_m) {
    // A formal sigma falls with the square root of the number of like boards: how many would
    // bring it under the gate, for the user to act on.
    const double ratio = std::max(q.rotation_sigma_deg / v.max_rotation_sigma_deg,
                                  q.translation_sigma_m / v.max_translation_sigma_m);
    const double needed = std::ceil(q.boards_used * ratio * ratio);
    return refuse(
        Reason::kPoorObservability,
        "formal sigma " + FixedDecimal(q.rotation_sigma_deg, 4) + " deg / " +
            FixedDecimal(q.translation_sigma_m, 4) + " m above " +
            FixedDecimal(v.max_rotation_sigma_deg, 4) + " deg / " +
            FixedDecimal(v.max_translation_sigma_m, 4) + " m: boards too few or too alike (" +
            std::to_string(q.boards_used) + " boards; about " +
            (std::isfinite(needed) && needed < 1e6 ? FixedDecimal(needed, 0) : "many more") +
            " like them, or fewer at closer range and more varied angles, where the "
            "LiDAR puts more points on each)");
  }
  if (q.principal_point_fitted) {
    // A principal point off by d turns the result by about d / f, which the LiDAR cannot see.
    const Eigen::Vector2d d = q.principal_point_shift_px;
    const double turn_deg = q.principal_point_turn_deg;
    const double chi2 = (d.cwiseQuotient(q.principal_point_sigma_px)).squaredNorm();
    const double max_turn_deg = kPrincipalPointTurnTolerances * v.verify_rotation_deg;
    // Groups of observations that disagree by far more than the turn that matters, and corners
    // that fit the lens model worse than detection explains: a wrong lens model. (Groups of a
    // short session can scatter as much with corners that fit: not refused for that alone.)
    const Eigen::Vector2d s = q.principal_point_sigma_px;
    const double sigma_turn_deg = std::hypot(s.x() / camera.fx, s.y() / camera.fy) * kRad2Deg;
    const double max_sigma_turn_deg = kPrincipalPointSigmaTurns * max_turn_deg;
    if (sigma_turn_deg > max_sigma_turn_deg &&
        q.principal_point_residual_px > kLensMisfitResidualPx)
      return refuse(
          Reason::kPrincipalPointMismatch,
          "the tags do not agree on the camera's principal point: +-" + FixedDecimal(s.x(), 1) +
              " / +-" + FixedDecimal(s.y(), 1) +
              " px from one group of observations to the next, a turn of " +
              FixedDecimal(sigma_turn_deg, 2) + " deg, more than " +
              FixedDecimal(max_sigma_turn_deg, 2) +
              " deg; their corners fit the configured lens with " +
              FixedDecimal(q.principal_point_residual_px, 2) +
              " px RMS: the camera's intrinsic calibration (its lens distortion or principal "
              "point) is likely wrong; calibrate the camera's intrinsics again (if they are "
              "right, boards closer to the camera and turned 20-40 deg let the tags check them)");
    if (turn_deg + kPrincipalPointTurnSigmas * sigma_turn_deg > max_turn_deg &&
        chi2 > kPrincipalPointChiSquare)
      return refuse(
          Reason::kPrincipalPointMismatch,
          "the tags put the camera's principal point " + FixedDecimal(d.x(), 1) + " px (+-" +
              FixedDecimal(q.principal_point_sigma_px.x(), 1) + ") right and " +
              FixedDecimal(d.y(), 1) + " px (+-" + FixedDecimal(q.principal_point_sigma_px.y(), 1) +
              ") down of the configured one, which turns the result by " +
              FixedDecimal(turn_deg, 2) + " deg (+-" + FixedDecimal(sigma_turn_deg, 2) +
              "), possibly more than " + FixedDecimal(max_turn_deg, 2) +
              " deg: the camera's intrinsic calibration (its principal point, or its focal "
              "length) is wrong or belongs to another camera; calibrate the camera's "
              "intrinsics again");
  }
  if (std::fabs(q.camera_scale_error) > v.max_camera_scale_error &&
      std::fabs(q.camera_scale_error) > kScaleSigmas * q.camera_scale_sigma)
    return refuse(Reason::kCameraScaleMismatch,
                  "the camera's board distances are " +
                      FixedDecimal(std::fabs(q.camera_scale_error) * 100.0, 2) + " % (+-" +
                      FixedDecimal(q.camera_scale_sigma * 100.0, 2) + ") " +
                      (q.camera_scale_error > 0.0 ? "longer" : "shorter") +
                      " than the LiDAR's, more than " +
                      FixedDecimal(v.max_camera_scale_error * 100.0, 2) +
                      " %: the tag size (or checkerboard square) or the camera's focal length in "
                      "the configuration is wrong by about as much");
  if (std::fabs(q.lidar_range_offset_m) > v.max_lidar_range_offset_m &&
      std::fabs(q.lidar_range_offset_m) > kRangeOffsetSigmas * q.lidar_range_offset_sigma_m &&
      q.lidar_range_offset_sigma_m <= kMeasuredRangeOffsetShare * v.max_lidar_range_offset_m)
    return refuse(Reason::kLidarRangeOffset,
                  "the LiDAR's ranges are " +
                      FixedDecimal(std::fabs(q.lidar_range_offset_m) * 100.0, 1) + " cm (+-" +
                      FixedDecimal(q.lidar_range_offset_sigma_m * 100.0, 1) + ") " +
                      (q.lidar_range_offset_m > 0.0 ? "longer" : "shorter") +
                      " than the camera's board distances say, more than " +
                      FixedDecimal(v.max_lidar_range_offset_m * 100.0, 1) +
                      " cm: the translation would be off by about as much; have the LiDAR's range "
                      "calibration checked (or the board thickness and tag print: the tag's face "
                      "must be the board's front)");
  if (q.ring_elevation_chi2 > kRingElevationChi2 &&
      q.ring_elevation_rms_deg > kMinRingElevationRmsDeg)
    return refuse(Reason::kLidarRingElevation,
                  "the LiDAR's lasers do not fire at the elevations of the configured model's "
                  "table: over " +
                      std::to_string(q.ring_elevation_rings) +
                      " rings seen on the boards, their elevations scatter by " +
                      FixedDecimal(q.ring_elevation_rms_deg, 3) + " deg RMS, " +
                      FixedDecimal(std::sqrt(q.ring_elevation_chi2), 1) +
                      " times what their noise explains: the sensor's per-laser calibration (its "
                      "elevation table) is not the one its driver applies, or the LiDAR is not the "
                      "configured model; have the LiDAR's calibration checked (or load its own "
                      "calibration file into its driver)");
  // A range offset the boards do not measure could be in the translation unseen.
  const double max_range_sigma_m = kRangeOffsetSigmaTolerances * v.verify_translation_m;
  if (!(q.lidar_range_offset_sigma_m <= max_range_sigma_m))
    return refuse(Reason::kPoorObservability,
                  std::isfinite(q.lidar_range_offset_sigma_m)
                      ? "the boards measure the LiDAR's range offset only to +-" +
                            FixedDecimal(q.lidar_range_offset_sigma_m * 100.0, 1) + " cm (" +
                            FixedDecimal(max_range_sigma_m * 100.0, 1) +
                            " cm or better is needed): an offset that moved the translation by "
                            "centimetres would go unseen; record boards in more varied directions "
                            "(left and right of the LiDAR's axis, nearer, turned towards it)"
                      : "the boards cannot measure the LiDAR's range offset (" +
                            std::to_string(q.boards_used) + " board correspondences; " +
                            std::to_string(kMinScaleBoards) +
                            " or more, in varied directions, are needed), which would move the "
                            "translation by as much unseen; record more poses");
  const double max_scale_translation_m = kScaleTranslationTolerances * v.verify_translation_m;
  if (q.camera_scale_translation_m > max_scale_translation_m)
    return refuse(Reason::kPoorObservability,
                  "the camera measures the boards' distances against the LiDAR's only to +-" +
                      FixedDecimal(q.camera_scale_sigma * 100.0, 2) + " % at " +
                      FixedDecimal(q.camera_scale_translation_m / q.camera_scale_sigma, 1) +
                      " m on average, which leaves the translation uncertain by +-" +
                      FixedDecimal(q.camera_scale_translation_m * 100.0, 1) + " cm (" +
                      FixedDecimal(max_scale_translation_m * 100.0, 1) +
                      " cm or better is needed): the tags are too small in the image; bring "
                      "the boards closer to the camera or use larger tags");
  // After the scale and range gates: a wrong scale also spreads the boards' distances, and so
  // the time offset's sigma; its own words name the cause.
  if (q.time_offset_fitted && std::fabs(q.time_offset_s) > v.max_time_offset_s &&
      std::fabs(q.time_offset_s) > kTimeOffsetSigmas * q.time_offset_sigma_s)
    return refuse(Reason::kTimeOffset,
                  "the camera captured its images " +
                      FixedDecimal(std::fabs(q.time_offset_s) * 1e3, 1) + " ms (+-" +
                      FixedDecimal(q.time_offset_sigma_s * 1e3, 1) + ") " +
                      (q.time_offset_s > 0.0 ? "later" : "earlier") +
                      " than their stamps say against the LiDAR's, more than " +
                      FixedDecimal(v.max_time_offset_s * 1e3, 0) +
                      " ms: correct the camera's time stamping (its trigger delay and exposure, "
                      "or the clock synchronisation) and calibrate again");
  if (q.rotation_spread_deg > v.max_rotation_spread_deg ||
      q.translation_spread_m > v.max_translation_spread_m)
    return refuse(Reason::kUnstableSolution, "half-data re-solves move it by " +
                                                 FixedDecimal(q.rotation_spread_deg) + " deg / " +
                                                 FixedDecimal(q.translation_spread_m) + " m");
  if (q.start_rotation_deg > v.max_start_rotation_deg ||
      q.start_translation_m > v.max_start_translation_m)
    return refuse(Reason::kUnstableSolution,
                  "solves started " + FixedDecimal(kStartCheckRotationDeg, 0) + " deg / " +
                      FixedDecimal(kStartCheckTranslationM, 2) + " m away end " +
                      FixedDecimal(q.start_rotation_deg) + " deg / " +
                      FixedDecimal(q.start_translation_m) +
                      " m from it: the cost has more than one minimum (boards too few or too "
                      "alike, or paired with the wrong LiDAR cluster); record more, varied poses");
  if (q.reprojection_mean_px > q.reprojection_gate_px)
    return refuse(Reason::kHighReprojectionError,
                  "mean " + FixedDecimal(q.reprojection_mean_px, 2) + " px above " +
                      FixedDecimal(q.reprojection_gate_px, 2) + " px" +
                      (q.reprojection_gate_px > v.max_reprojection_mean_px
                           ? " (" + FixedDecimal(kReprojectionSpacingShare, 1) +
                                 " of the LiDAR's point spacing on the boards, " +
                                 FixedDecimal(q.lidar_spacing_px, 1) + " px)"
                           : std::string()));
  if (q.residual_rms_m > v.max_residual_rms_m)
    return refuse(Reason::kHighResidual, "point-to-board RMS " + FixedDecimal(q.residual_rms_m, 4) +
                                             " m above " + FixedDecimal(v.max_residual_rms_m, 4) +
                                             " m");
  if (out.delta_rotation_deg > v.max_rotation_deg || out.delta_translation_m > v.max_translation_m)
    return refuse(Reason::kDeltaBeyondTolerance,
                  "change from the prior " + FixedDecimal(out.delta_rotation_deg) + " deg / " +
                      FixedDecimal(out.delta_translation_m) + " m exceeds " +
                      FixedDecimal(v.max_rotation_deg) + " deg / " +
                      FixedDecimal(v.max_translation_m) + " m");
  return Reason::kNone;
}

}  // namespace calibd::detail
