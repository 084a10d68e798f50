#include "calibd/core/verdict/gates/ring_elevation_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"

namespace calibd {

Reason CheckRingElevations(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(q.ring_elevation_chi2 > kRingElevationChi2 &&
        q.ring_elevation_rms_deg > kMinRingElevationRmsDeg))
    return Reason::kNone;
  return Refuse(detail, Reason::kLidarRingElevation,
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
}

}  // namespace calibd
