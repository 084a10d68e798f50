#pragma once
/// \file
/// Stability gates: re-solves on random halves of the data, and solves from other starts, must end
/// near the solution (QualityFigures::rotation_spread_deg, start_rotation_deg); otherwise
/// `unstable_solution`.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct StabilityGateConfig {
  double max_rotation_spread_deg = 0.25;  ///< half-data re-solve gates (stability)
  double max_translation_spread_m = 0.03;
  /// Start gates (stability): the solves from EngineConfig::start_checks other starts must end
  /// this close to the solution; farther, the cost has another minimum there. Within one minimum
  /// they end a few hundredths of a degree apart (half the points each, and the board-pose
  /// alternation stops short of the joint optimum); a minimum closer than two thirds of the
  /// verification tolerance would not change what the verdict means.
  double max_start_rotation_deg = 0.1;
  double max_start_translation_m = 0.01;
};

/// How far the start checks (EngineConfig::start_checks) start from the solution: two grid-search
/// steps and a mounting tolerance's worth, within the optimiser's basin when the data leave one.
inline constexpr double kStartCheckRotationDeg = 3.0;
inline constexpr double kStartCheckTranslationM = 0.05;

Reason CheckHalfDataSpread(const GateInput& in, std::string* detail);
Reason CheckStartChecks(const GateInput& in, std::string* detail);

}  // namespace calibd
