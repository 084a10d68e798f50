#include "calibd/core/verdict/gates/reprojection_gate.hpp"

#include <algorithm>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

double ReprojectionGatePx(const ReprojectionGateConfig& c, double lidar_spacing_px) {
  return std::max(c.max_reprojection_mean_px, kReprojectionSpacingShare * lidar_spacing_px);
}

Reason CheckReprojection(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(q.reprojection_mean_px > q.reprojection_gate_px)) return Reason::kNone;
  return Refuse(detail, Reason::kHighReprojectionError,
                "mean " + FixedDecimal(q.reprojection_mean_px, 2) + " px above " +
                    FixedDecimal(q.reprojection_gate_px, 2) + " px" +
                    (q.reprojection_gate_px > in.config.max_reprojection_mean_px
                         ? " (" + FixedDecimal(kReprojectionSpacingShare, 1) +
                               " of the LiDAR's point spacing on the boards, " +
                               FixedDecimal(q.lidar_spacing_px, 1) + " px)"
                         : std::string()));
}

}  // namespace calibd
