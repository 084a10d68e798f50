#pragma once
/// \file
/// The error bound's gate (QualityFigures::rotation_bound_deg, translation_bound_m; ErrorBound
/// in measure_quality.hpp): a result is accepted (`updated` or `verified`) only when its own
/// predicted 99 % error bound lies inside the accuracy it must have. Asked after every gate that
/// names a specific fault, so that a fault is named as such; its refusal names the bound's
/// largest part and what would shrink it.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct ErrorBoundGateConfig {
  /// The accuracy a result must be known to, at 99 %: twice the verification tolerance, the
  /// error the fault campaign counts as wrong (calibd-bench verdicts).
  double max_rotation_bound_deg = 0.30;
  double max_translation_bound_m = 0.03;
};

Reason CheckErrorBound(const GateInput& in, std::string* detail);

}  // namespace calibd
