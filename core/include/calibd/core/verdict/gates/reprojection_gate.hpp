#pragma once
/// \file
/// Reprojection gate (paper Table I metric, QualityFigures::reprojection_mean_px against
/// reprojection_gate_px): `high_reprojection_error`.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct ReprojectionGateConfig {
  /// Paper Table I metric. It measures each board's own LiDAR fit as much as the extrinsic:
  /// correct results stay well under it (calibd-bench calib's Table I), and a rotation error of
  /// 0.1 deg adds fx * 0.1 deg, about 6 px at fx = 3325 px: 8 px still catches errors near the
  /// verification tolerance.
  double max_reprojection_mean_px = 8.0;  ///< raised for a sparse LiDAR: ReprojectionGatePx
};

/// The mean reprojection error a correct result stays under, as a share of the LiDAR's point
/// spacing on the boards (QualityFigures::lidar_spacing_px): each board's fit places its tag
/// corners to about a third of a spacing (clean sessions of ring, MEMS and non-repetitive LiDARs,
/// calibd-bench verdicts), so a sparse LiDAR's boards miss by more pixels than a dense one's
/// whatever the extrinsic.
inline constexpr double kReprojectionSpacingShare = 0.6;

/// The gate applied (QualityFigures::reprojection_gate_px): max_reprojection_mean_px, or
/// kReprojectionSpacingShare of the LiDAR's spacing where it resolves the boards coarser.
double ReprojectionGatePx(const ReprojectionGateConfig& c, double lidar_spacing_px);

Reason CheckReprojection(const GateInput& in, std::string* detail);

}  // namespace calibd
