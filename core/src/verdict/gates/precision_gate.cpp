#include "calibd/core/verdict/gates/precision_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckPlaneConditioning(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(q.plane_conditioning < v.min_plane_conditioning)) return Reason::kNone;
  return Refuse(detail, Reason::kPoorObservability,
                "the board planes leave a direction unconstrained (conditioning " +
                    FixedDecimal(q.plane_conditioning, 6) + " below " +
                    FixedDecimal(v.min_plane_conditioning, 6) +
                    "): boards too few or all parallel");
}

Reason CheckFormalSigmas(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  // Each gate only where set (PrecisionGateConfig).
  const auto over = [](double sigma, double max) { return max > 0.0 ? sigma / max : 0.0; };
  const double ratio = std::max(over(q.rotation_sigma_deg, v.max_rotation_sigma_deg),
                                over(q.translation_sigma_m, v.max_translation_sigma_m));
  if (!(ratio > 1.0)) return Reason::kNone;
  // A formal sigma falls with the square root of the number of like boards: how many would
  // bring it under the gate, for the user to act on.
  const double needed = std::ceil(q.boards_used * ratio * ratio);
  const auto limit = [](double max, const char* unit) {
    return max > 0.0 ? FixedDecimal(max, 4) + unit : std::string("no gate");
  };
  return Refuse(
      detail, Reason::kPoorObservability,
      "formal sigma " + FixedDecimal(q.rotation_sigma_deg, 4) + " deg / " +
          FixedDecimal(q.translation_sigma_m, 4) + " m above " +
          limit(v.max_rotation_sigma_deg, " deg") + " / " + limit(v.max_translation_sigma_m, " m") +
          ": boards too few or too alike (" + std::to_string(q.boards_used) + " boards; about " +
          (std::isfinite(needed) && needed < 1e6 ? FixedDecimal(needed, 0) : "many more") +
          " like them, or fewer at closer range and more varied angles, where the "
          "LiDAR puts more points on each)");
}

}  // namespace calibd
