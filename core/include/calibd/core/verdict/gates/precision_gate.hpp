#pragma once
/// \file
/// Precision gates: the board planes must constrain every direction (conditioning), and, where a
/// site asks for them, the formal sigmas of the solution must be small; otherwise
/// `poor_observability`, with how many boards would bring the sigmas under their gate.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

struct PrecisionGateConfig {
  /// Degeneracy gate: smallest / largest eigenvalue of the board-plane information, rotations
  /// scaled by a 10 m lever arm. One board, or parallel boards, drive it towards 0.
  double min_plane_conditioning =
      1e-5;  // measured: 3 spread boards 9e-5, one board 1e-6, parallel 2e-8
  /// Formal standard deviation gates, 0: none (the default). The error bound judges the
  /// result's precision (error_bound_gate.hpp) with the clustered covariance, which the formal
  /// sigma (every LiDAR point taken as independent) understates 2-6 times on clean sessions;
  /// at 0.05 deg / 1 cm these gates only refused sessions the bound refused as well, or
  /// accurate ones inside it (a Mid-360's still poses at 0.052 deg, 0.04 deg off, bound 0.24 deg
  /// / 2.7 cm). A site may still demand a formal precision.
  double max_rotation_sigma_deg = 0.0;
  double max_translation_sigma_m = 0.0;
};

Reason CheckPlaneConditioning(const GateInput& in, std::string* detail);
Reason CheckFormalSigmas(const GateInput& in, std::string* detail);

}  // namespace calibd
