#include "calibd/core/verdict/gates/prior_tolerance_gate.hpp"

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckDeltaFromPrior(const GateInput& in, std::string* detail) {
  const VerdictConfig& v = in.config;
  if (!(in.delta_rotation_deg > v.max_rotation_deg || in.delta_translation_m > v.max_translation_m))
    return Reason::kNone;
  return Refuse(detail, Reason::kDeltaBeyondTolerance,
                "change from the prior " + FixedDecimal(in.delta_rotation_deg) + " deg / " +
                    FixedDecimal(in.delta_translation_m) + " m exceeds " +
                    FixedDecimal(v.max_rotation_deg) + " deg / " +
                    FixedDecimal(v.max_translation_m) + " m");
}

bool WithinVerification(const PriorToleranceConfig& c, double delta_rotation_deg,
                        double delta_translation_m) {
  return delta_rotation_deg <= c.verify_rotation_deg &&
         delta_translation_m <= c.verify_translation_m;
}

}  // namespace calibd
