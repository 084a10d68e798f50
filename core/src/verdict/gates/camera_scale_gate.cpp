#include "calibd/core/verdict/gates/camera_scale_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/camera_scale.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckCameraScale(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(std::fabs(q.camera_scale_error) > v.max_camera_scale_error &&
        std::fabs(q.camera_scale_error) > kScaleSigmas * q.camera_scale_sigma))
    return Reason::kNone;
  return Refuse(detail, Reason::kCameraScaleMismatch,
                "the camera's board distances are " +
                    FixedDecimal(std::fabs(q.camera_scale_error) * 100.0, 2) + " % (+-" +
                    FixedDecimal(q.camera_scale_sigma * 100.0, 2) + ") " +
                    (q.camera_scale_error > 0.0 ? "longer" : "shorter") +
                    " than the LiDAR's, more than " +
                    FixedDecimal(v.max_camera_scale_error * 100.0, 2) +
                    " %: the tag size (or checkerboard square) or the camera's focal length in "
                    "the configuration is wrong by about as much");
}

Reason CheckScaleObservable(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const double max_scale_translation_m =
      kScaleTranslationTolerances * in.config.verify_translation_m;
  if (!(q.camera_scale_translation_m > max_scale_translation_m)) return Reason::kNone;
  return Refuse(detail, Reason::kPoorObservability,
                "the camera measures the boards' distances against the LiDAR's only to +-" +
                    FixedDecimal(q.camera_scale_sigma * 100.0, 2) + " % at " +
                    FixedDecimal(q.camera_scale_translation_m / q.camera_scale_sigma, 1) +
                    " m on average, which leaves the translation uncertain by +-" +
                    FixedDecimal(q.camera_scale_translation_m * 100.0, 1) + " cm (" +
                    FixedDecimal(max_scale_translation_m * 100.0, 1) +
                    " cm or better is needed): the tags are too small in the image; bring "
                    "the boards closer to the camera or use larger tags");
}

}  // namespace calibd
