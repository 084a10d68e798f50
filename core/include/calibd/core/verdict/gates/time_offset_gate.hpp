#pragma once
/// \file
/// Time offset gate (QualityFigures::time_offset_s, board_motion.hpp): asked after the scale and
/// range gates, since a wrong scale also spreads the boards' distances, and so the time offset's
/// sigma; its own words name the cause.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct TimeOffsetGateConfig {
  /// The solution is corrected for the camera's offset against the LiDAR up to this (how well:
  /// calibd-bench time-offset); beyond it and kTimeOffsetSigmas of its sigma the stamping is
  /// broken rather than late, and the verdict is `time_offset_beyond_tolerance`. A session that
  /// cannot measure the offset (still boards, no capture times, or a drive whose boards' speed
  /// along their normals hardly varies) relies on the stamps: QualityFigures says how far an
  /// offset as large as its sigma would move the translation.
  double max_time_offset_s = 0.1;
};

/// A time offset is corrected for (and refused) only beyond this many of its standard deviations.
inline constexpr double kTimeOffsetSigmas = 3.0;

Reason CheckTimeOffset(const GateInput& in, std::string* detail);

}  // namespace calibd
