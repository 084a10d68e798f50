#include "calibd/core/verdict/gates/time_offset_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckTimeOffset(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(q.time_offset_fitted && std::fabs(q.time_offset_s) > v.max_time_offset_s &&
        std::fabs(q.time_offset_s) > kTimeOffsetSigmas * q.time_offset_sigma_s))
    return Reason::kNone;
  return Refuse(detail, Reason::kTimeOffset,
                "the camera captured its images " +
                    FixedDecimal(std::fabs(q.time_offset_s) * 1e3, 1) + " ms (+-" +
                    FixedDecimal(q.time_offset_sigma_s * 1e3, 1) + ") " +
                    (q.time_offset_s > 0.0 ? "later" : "earlier") +
                    " than their stamps say against the LiDAR's, more than " +
                    FixedDecimal(v.max_time_offset_s * 1e3, 0) +
                    " ms: correct the camera's time stamping (its trigger delay and exposure, "
                    "or the clock synchronisation) and calibrate again");
}

}  // namespace calibd
