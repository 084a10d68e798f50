#pragma once
/// \file
/// Ring gate (QualityFigures::ring_elevation_*, ring_elevations.hpp): the rings' elevation deltas
/// scatter by more than kRingElevationChi2 times their variance (mean squared sigmas) and by more
/// than kMinRingElevationRmsDeg: `lidar_ring_elevation`.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

/// Set between what clean ring LiDARs' sessions scatter by and what lasers off their table by
/// enough to move the result make (docs/performance-and-reliability.md, "Why the thresholds are
/// where they are").
inline constexpr double kRingElevationChi2 = 10.0;
inline constexpr double kMinRingElevationRmsDeg = 0.05;

Reason CheckRingElevations(const GateInput& in, std::string* detail);

}  // namespace calibd
