#include "calibd/core/verdict/gates/residual_gate.hpp"

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckResidual(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(q.residual_rms_m > in.config.max_residual_rms_m)) return Reason::kNone;
  return Refuse(detail, Reason::kHighResidual,
                "point-to-board RMS " + FixedDecimal(q.residual_rms_m, 4) + " m above " +
                    FixedDecimal(in.config.max_residual_rms_m, 4) + " m");
}

}  // namespace calibd
