#include "calibd/core/verdict/gates/error_bound_gate.hpp"

#include <cmath>
#include <string>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/measure_quality.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

namespace {

std::string Bound(double x, int decimals) {
  return std::isfinite(x) ? FixedDecimal(x, decimals) : std::string("unknown");
}

// The camera's scale as the tags read it against the LiDAR, and how much was corrected.
std::string CameraScaleText(const QualityFigures& q) {
  return FixedDecimal(q.camera_scale_error * 100.0, 2) + " +-" +
         FixedDecimal(q.camera_scale_sigma * 100.0, 2) + " % off the LiDAR's, " +
         FixedDecimal(q.camera_scale_corrected * 100.0, 2) + " % corrected";
}

// The rotation bound's larger part, and what would shrink it.
std::string RotationCause(const GateInput& in) {
  const QualityFigures& q = in.quality;
  // The scatter first only when it alone reaches the tolerance and outweighs the principal point.
  const bool scatter_alone_out = !(q.rotation_statistical_deg <= in.config.max_rotation_bound_deg);
  if (scatter_alone_out && q.rotation_statistical_deg >= q.rotation_systematic_deg)
    return "most of it the boards' own scatter (+-" +
           FixedDecimal(q.rotation_clustered_sigma_deg, 3) +
           " deg): more boards, closer and at more varied angles";
  // The time offset where it outweighs the principal point's part of the systematic bound.
  if (q.rotation_bound_time_offset_deg > 0.5 * q.rotation_systematic_deg)
    return "most of it the camera's time offset against the LiDAR while the boards move (" +
           FixedDecimal((q.time_offset_s - q.time_offset_corrected_s) * 1e3, 1) + " +-" +
           FixedDecimal(q.time_offset_sigma_s * 1e3, 1) +
           " ms left after the correction, which turns the result by up to " +
           FixedDecimal(q.rotation_bound_time_offset_deg, 2) +
           " deg): boards held still during each pose, or stamps of the camera's capture time";
  // The camera's scale, likewise: the tags' size or the focal length.
  if (q.rotation_bound_camera_scale_deg > 0.5 * q.rotation_systematic_deg)
    return "most of it the camera's scale against the LiDAR (its board distances " +
           CameraScaleText(q) + ", which turns the result by up to " +
           FixedDecimal(q.rotation_bound_camera_scale_deg, 2) +
           " deg): measure the tags' printed size (boards[].tag_size_m) and check the camera's "
           "focal length";
  const Eigen::Vector2d d = q.principal_point_shift_px;
  if (q.principal_point_bound_corners == CornerBias::kNone)
    return "most of it the camera's principal point, which the LiDAR cannot see: the tags put it " +
           FixedDecimal(d.x(), 1) + " px right and " + FixedDecimal(d.y(), 1) +
           " px down of the configured one (+-" + FixedDecimal(q.principal_point_sigma_px.x(), 1) +
           " / +-" + FixedDecimal(q.principal_point_sigma_px.y(), 1) +
           " px): taken as they read it, the result may turn that far; they measure it too "
           "loosely to confirm or refute the intrinsic calibration's +-" +
           FixedDecimal(q.principal_point_stated_sigma_px, 1) +
           " px: check the camera's intrinsic calibration (cx, cy), or add still poses with "
           "boards close to the camera (1.5-3 m) turned 20-40 deg";
  const std::string known =
      q.principal_point_fitted
          ? "the tags measure it to +-" + FixedDecimal(q.principal_point_turn_sigma_deg, 2) +
                " deg of turn, and their corners' own bias could move it " +
                FixedDecimal(PrincipalPointTurnDeg(q.principal_point_systematic_px, in.camera), 2) +
                " deg"
          : "the tags could not measure it";
  // The statement taken no sharper than the tags could check.
  const double tags_sigma_px = q.principal_point_sigma_px.maxCoeff();
  if (StatedSigmaWidened(q.principal_point_stated_sigma_px, q.principal_point_sigma_px) > 0.0)
    return "most of it the camera's principal point, which the LiDAR cannot see (" + known +
           ", too loosely to check the intrinsic calibration's +-" +
           FixedDecimal(q.principal_point_stated_sigma_px, 1) + " px, taken at most " +
           FixedDecimal(kMaxStatedSharpening, 0) + " times sharper than their +-" +
           FixedDecimal(tags_sigma_px, 1) +
           " px): still poses with boards close to the camera (1.5-3 m) turned 20-40 deg, "
           "over the whole image";
  if (q.principal_point_stated_sigma_px > 0.0)
    return "most of it the camera's principal point, which the LiDAR cannot see (" + known +
           "; the intrinsic calibration states +-" +
           FixedDecimal(q.principal_point_stated_sigma_px, 1) +
           " px): a more precise intrinsic calibration, or still poses with boards close to the "
           "camera (1.5-3 m) turned 20-40 deg";
  return "most of it the camera's principal point, which the LiDAR cannot see (" + known +
         "): set camera.principal_point_sigma_px to the sigma the camera's intrinsic "
         "calibration states for cx and cy, or add still poses with boards close to the camera "
         "(1.5-3 m) turned 20-40 deg";
}

// The translation bound's largest part, and what would shrink it.
std::string TranslationCause(const QualityFigures& q) {
  const double statistical_m = kBoundNormQuantile3d * q.translation_clustered_sigma_m;
  const double range_m = q.translation_bound_range_offset_m;
  const double scale_m = q.translation_bound_scale_m;
  const double time_m = q.translation_bound_time_offset_m;
  const double principal_point_m = q.translation_bound_principal_point_m;
  const double board_centre_m = q.translation_bound_board_centre_m;
  if (board_centre_m >= statistical_m && board_centre_m >= range_m && board_centre_m >= scale_m &&
      board_centre_m >= time_m && board_centre_m >= principal_point_m)
    return "most of it where the boards' centres lie about their tags: the camera sees board " +
           std::to_string(q.board_centre_offset_id) + "'s edges put its centre " +
           FixedDecimal(q.board_centre_offset_m.x() * 1e3, 1) + " mm right and " +
           FixedDecimal(q.board_centre_offset_m.y() * 1e3, 1) + " mm up (+-" +
           FixedDecimal(q.board_centre_offset_sigma_m.x() * 1e3, 1) + " / +-" +
           FixedDecimal(q.board_centre_offset_sigma_m.y() * 1e3, 1) +
           " mm) of where the config's board size and tag offset put it, facing the tag: measure "
           "the tag's position on the board (boards[].tag_offset_m) and the board's size";
  if (principal_point_m >= statistical_m && principal_point_m >= range_m &&
      principal_point_m >= scale_m && principal_point_m >= time_m)
    return "most of it the camera's principal point (" +
           FixedDecimal(q.principal_point_belief.shift_px.x(), 1) + ", " +
           FixedDecimal(q.principal_point_belief.shift_px.y(), 1) + " px +-" +
           FixedDecimal(q.principal_point_belief.sigma_px.x(), 1) + " / +-" +
           FixedDecimal(q.principal_point_belief.sigma_px.y(), 1) +
           " from the configured one, as the tags and the intrinsic calibration know it), which "
           "the boards' poses carry into the translation: check the camera's intrinsic "
           "calibration, or add still poses with boards close to the camera (1.5-3 m) turned "
           "20-40 deg";
  if (range_m >= statistical_m && range_m >= scale_m && range_m >= time_m)
    return "most of it the LiDAR's range offset (" + FixedDecimal(q.lidar_range_offset_m * 100, 1) +
           " +-" + FixedDecimal(q.lidar_range_offset_sigma_m * 100, 1) +
           " cm), which boards all ahead of the LiDAR cannot tell from its position along them: "
           "boards to the sides as well, or still poses around the sensors";
  if (scale_m >= statistical_m && scale_m >= time_m)
    return "most of it the boards' distances as the tags measure them (the camera's scale " +
           CameraScaleText(q) +
           "): measure the tags' printed size (boards[].tag_size_m) and check the "
           "camera's focal length; or boards closer to the camera, or larger tags";
  if (time_m >= statistical_m)
    return "most of it the camera's time offset against the LiDAR while the boards move: "
           "boards held still, or slower";
  return "most of it the boards' own scatter (+-" +
         FixedDecimal(q.translation_clustered_sigma_m * 100, 2) +
         " cm): more boards, closer and at more varied angles";
}

}  // namespace

Reason CheckErrorBound(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  const bool rotation_out = !(q.rotation_bound_deg <= v.max_rotation_bound_deg);
  const bool translation_out = !(q.translation_bound_m <= v.max_translation_bound_m);
  if (!rotation_out && !translation_out) return Reason::kNone;
  std::string text = "this result's error could reach " + Bound(q.rotation_bound_deg, 2) +
                     " deg / " + Bound(q.translation_bound_m * 100, 1) +
                     " cm (its 99 % bound), more than the " +
                     FixedDecimal(v.max_rotation_bound_deg, 2) + " deg / " +
                     FixedDecimal(v.max_translation_bound_m * 100, 1) + " cm it must be known to";
  if (!q.has_error_bound() && !std::isfinite(q.rotation_clustered_sigma_deg))
    return Refuse(detail, Reason::kPoorObservability,
                  text +
                      ": the boards' scatter could not be measured (too few stretches of "
                      "frames or boards): more boards over a longer session");
  if (rotation_out) text += "; rotation: " + RotationCause(in);
  if (translation_out) text += "; translation: " + TranslationCause(q);
  return Refuse(detail, Reason::kPoorObservability, text);
}

}  // namespace calibd
