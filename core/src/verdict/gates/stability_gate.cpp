#include "calibd/core/verdict/gates/stability_gate.hpp"

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckHalfDataSpread(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(q.rotation_spread_deg > v.max_rotation_spread_deg ||
        q.translation_spread_m > v.max_translation_spread_m))
    return Reason::kNone;
  return Refuse(detail, Reason::kUnstableSolution,
                "half-data re-solves move it by " + FixedDecimal(q.rotation_spread_deg) +
                    " deg / " + FixedDecimal(q.translation_spread_m) + " m");
}

Reason CheckStartChecks(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(q.start_rotation_deg > v.max_start_rotation_deg ||
        q.start_translation_m > v.max_start_translation_m))
    return Reason::kNone;
  return Refuse(detail, Reason::kUnstableSolution,
                "solves started " + FixedDecimal(kStartCheckRotationDeg, 0) + " deg / " +
                    FixedDecimal(kStartCheckTranslationM, 2) + " m away end " +
                    FixedDecimal(q.start_rotation_deg) + " deg / " +
                    FixedDecimal(q.start_translation_m) +
                    " m from it: the cost has more than one minimum (boards too few or too "
                    "alike, or paired with the wrong LiDAR cluster); record more, varied poses");
}

}  // namespace calibd
