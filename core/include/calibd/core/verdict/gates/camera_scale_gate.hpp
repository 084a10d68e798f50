#pragma once
/// \file
/// Camera scale gates (QualityFigures::camera_scale_*, camera_scale.hpp): a scale the engine could
/// not correct for is a wrong configuration (`camera_scale_mismatch`); one measured too loosely
/// leaves the translation uncertain (`poor_observability`).

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct CameraScaleGateConfig {
  /// Scale (QualityFigures::camera_scale_error): a tag size or focal length 1 % off moves the
  /// translation by 1 % of the boards' distance, more than the verification tolerance beyond a
  /// metre and a half. Measured beyond kScaleSigmas of its sigma, the session is corrected for it
  /// up to this share (QualityFigures::camera_scale_corrected); beyond, the configuration is wrong
  /// and the verdict is `camera_scale_mismatch`.
  double max_camera_scale_error = 0.015;
};

/// The translation rests on the camera's board distances (PnP, through the tag's size in the
/// image) wherever the LiDAR cannot pin the boards along their normals by itself: a scale error as
/// large as the scale's sigma moves it by that sigma times the boards' mean distance
/// (QualityFigures::camera_scale_translation_m). Beyond this many verification tolerances the
/// result is `poor_observability`: small far tags measure their distance too loosely, and their
/// corner bias is then taken for a scale, a range offset or a time offset and corrected for,
/// centimetres off (CalibrationEngineTest.SmallFarTagsAreRefusedNotTrusted).
inline constexpr double kScaleTranslationTolerances = 1.0;

Reason CheckCameraScale(const GateInput& in, std::string* detail);
Reason CheckScaleObservable(const GateInput& in, std::string* detail);

}  // namespace calibd
