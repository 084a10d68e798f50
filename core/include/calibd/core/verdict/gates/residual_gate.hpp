#pragma once
/// \file
/// Residual gate: the LiDAR's board points must lie near their boards at the solution
/// (QualityFigures::residual_rms_m): `high_residual`.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct ResidualGateConfig {
  double max_residual_rms_m = 0.05;
};

Reason CheckResidual(const GateInput& in, std::string* detail);

}  // namespace calibd
