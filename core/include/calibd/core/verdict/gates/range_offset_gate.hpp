#pragma once
/// \file
/// LiDAR range offset gates (QualityFigures::lidar_range_offset_*, range_offset.hpp): an offset
/// beyond its gate is `lidar_range_offset`; one the boards cannot measure could sit in the
/// translation unseen (`poor_observability`).

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct RangeOffsetGateConfig {
  /// Range offset gate (QualityFigures::lidar_range_offset_m): beyond this and kRangeOffsetSigmas
  /// of its sigma, `lidar_range_offset`. An offset moves the translation by about as much along the
  /// boards' mean direction, so the gate is the verification tolerance. Measured less precisely
  /// (its sigma above kMeasuredRangeOffsetShare of the gate) it does not fire; not measured to
  /// kRangeOffsetSigmaTolerances verification tolerances, the verdict is `poor_observability`.
  double max_lidar_range_offset_m = 0.015;
};

/// A range offset counts only beyond this many of its standard deviations: its sigma underrates
/// the in-plane centres' errors shared by a session's boards (clean sessions measured offsets of
/// three to four sigmas: docs/performance-and-reliability.md, "Why the thresholds are where they
/// are").
inline constexpr double kRangeOffsetSigmas = 4.0;
/// A range offset counts only when measured to this share of its gate: its sigma comes from the
/// boards' scatter, which underrates errors shared by all of a session's boards (the in-plane
/// centres' from the scan pattern's density, the plane distances' from PnP's bias).
inline constexpr double kMeasuredRangeOffsetShare = 0.5;
/// A range offset moves the translation by up to as much (all of it for boards straight ahead), so
/// a result is accepted only where the boards measure it at all: with a sigma of at most this
/// many verification tolerances (VerdictConfig::verify_translation_m); the rest is
/// `poor_observability`. Between kMeasuredRangeOffsetShare of the range gate and this, the
/// translation is as good as the LiDAR's range calibration (report.json gives the sigma): a
/// tighter bound refused clean m1 drives with a small camera, whose far boards' small tags bias
/// the in-plane centres (calibd-bench calib, Fig. 7 subsets; SensorFaultsTest).
inline constexpr double kRangeOffsetSigmaTolerances = 4.0;

Reason CheckRangeOffset(const GateInput& in, std::string* detail);
Reason CheckRangeOffsetObservable(const GateInput& in, std::string* detail);

}  // namespace calibd
