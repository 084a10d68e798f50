#pragma once
/// \file
/// Precision gates: the board planes must constrain every direction (conditioning), and the
/// formal sigmas of the solution must be small; otherwise `poor_observability`, with how many
/// boards would bring the sigmas under their gate.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct PrecisionGateConfig {
  /// Degeneracy gate: smallest / largest eigenvalue of the board-plane information, rotations
  /// scaled by a 10 m lever arm. One board, or parallel boards, drive it towards 0.
  double min_plane_conditioning =
      1e-5;  // measured: 3 spread boards 9e-5, one board 1e-6, parallel 2e-8
  double max_rotation_sigma_deg = 0.05;  ///< formal standard deviation gates (precision)
  double max_translation_sigma_m = 0.01;
};

Reason CheckPlaneConditioning(const GateInput& in, std::string* detail);
Reason CheckFormalSigmas(const GateInput& in, std::string* detail);

}  // namespace calibd
