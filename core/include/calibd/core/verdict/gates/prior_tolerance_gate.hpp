#pragma once
/// \file
/// The solution against the prior calibration: within the verification tolerance the prior is
/// `verified`; beyond the mechanical tolerance the change is `delta_beyond_tolerance`.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct PriorToleranceConfig {
  double verify_rotation_deg = 0.15;  ///< below both: `verified`, the prior is kept
  double verify_translation_m = 0.015;
  /// Mechanical tolerance: beyond it, `rejected`. A nominal prior from the mounting drawings is
  /// within about 10 deg / 20 cm of the truth (the grid search's reach), so a first calibration
  /// from one must pass it.
  double max_rotation_deg = 10.0;
  double max_translation_m = 0.20;
};

Reason CheckDeltaFromPrior(const GateInput& in, std::string* detail);

/// Within the verification tolerance of the prior: the prior is confirmed.
bool WithinVerification(const PriorToleranceConfig& c, double delta_rotation_deg,
                        double delta_translation_m);

}  // namespace calibd
