#include "calibd/core/verdict/gates/range_offset_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/camera_scale.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

Reason CheckRangeOffset(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  const VerdictConfig& v = in.config;
  if (!(std::fabs(q.lidar_range_offset_m) > v.max_lidar_range_offset_m &&
        std::fabs(q.lidar_range_offset_m) > kRangeOffsetSigmas * q.lidar_range_offset_sigma_m &&
        q.lidar_range_offset_sigma_m <= kMeasuredRangeOffsetShare * v.max_lidar_range_offset_m))
    return Reason::kNone;
  return Refuse(detail, Reason::kLidarRangeOffset,
                "the LiDAR's ranges are " +
                    FixedDecimal(std::fabs(q.lidar_range_offset_m) * 100.0, 1) + " cm (+-" +
                    FixedDecimal(q.lidar_range_offset_sigma_m * 100.0, 1) + ") " +
                    (q.lidar_range_offset_m > 0.0 ? "longer" : "shorter") +
                    " than the camera's board distances say, more than " +
                    FixedDecimal(v.max_lidar_range_offset_m * 100.0, 1) +
                    " cm: the translation would be off by about as much; have the LiDAR's range "
                    "calibration checked (or the board thickness and tag print: the tag's face "
                    "must be the board's front)");
}

Reason CheckRangeOffsetObservable(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  // A range offset the boards do not measure could be in the translation unseen.
  const double max_range_sigma_m = kRangeOffsetSigmaTolerances * in.config.verify_translation_m;
  if (q.lidar_range_offset_sigma_m <= max_range_sigma_m) return Reason::kNone;
  return Refuse(detail, Reason::kPoorObservability,
                std::isfinite(q.lidar_range_offset_sigma_m)
                    ? "the boards measure the LiDAR's range offset only to +-" +
                          FixedDecimal(q.lidar_range_offset_sigma_m * 100.0, 1) + " cm (" +
                          FixedDecimal(max_range_sigma_m * 100.0, 1) +
                          " cm or better is needed): an offset that moved the translation by "
                          "centimetres would go unseen; record boards in more varied directions "
                          "(left and right of the LiDAR's axis, nearer, turned towards it)"
                    : "the boards cannot measure the LiDAR's range offset (" +
                          std::to_string(q.boards_used) + " board correspondences; " +
                          std::to_string(kMinScaleBoards) +
                          " or more, in varied directions, are needed), which would move the "
                          "translation by as much unseen; record more poses");
}

}  // namespace calibd
