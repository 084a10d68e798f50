#include "calibd/core/verdict/gates/reprojection_gate.hpp"

#include <algorithm>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

double ReprojectionFocalPx(const CameraIntrinsics& camera) { return 0.5 * (camera.fx + camera.fy); }

double ReprojectionAnglePx(const ReprojectionGateConfig& c, double focal_px) {
  return focal_px * c.max_reprojection_mean_deg * kDeg2Rad;
}

double ReprojectionGatePx(const ReprojectionGateConfig& c, double focal_px,
                          double lidar_spacing_px) {
  return std::max(ReprojectionAnglePx(c, focal_px), kReprojectionSpacingShare * lidar_spacing_px);
}

Reason CheckReprojection(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(q.reprojection_mean_px > q.reprojection_gate_px)) return Reason::kNone;
  const double focal_px = ReprojectionFocalPx(in.camera);
  const double angle_px = ReprojectionAnglePx(in.config, focal_px);
  return Refuse(
      detail, Reason::kHighReprojectionError,
      "mean " + FixedDecimal(q.reprojection_mean_px, 2) + " px above " +
          FixedDecimal(q.reprojection_gate_px, 2) + " px" +
          (q.reprojection_gate_px > angle_px
               ? " (" + FixedDecimal(kReprojectionSpacingShare, 1) +
                     " of the LiDAR's point spacing on the boards, " +
                     FixedDecimal(q.lidar_spacing_px, 1) + " px)"
               : " (" + FixedDecimal(in.config.max_reprojection_mean_deg, 3) +
                     " deg at the camera's focal length, " + FixedDecimal(focal_px, 0) + " px)"));
}

}  // namespace calibd
