#pragma once
/// \file
/// Principal point gates (QualityFigures::principal_point_*, principal_point_check.hpp): a
/// principal point off by d turns the result by about d / f, which the LiDAR cannot see. Refused
/// as `principal_point_mismatch` when the tags disagree with each other on it and misfit the lens
/// (a wrong lens model), when the shift they agree on turns the result too far, or when they
/// put it beyond what the intrinsic calibration states (camera.principal_point_sigma_px).

#include "calibd/core/verdict/gate.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"

namespace calibd {

/// A principal point shift counts only when its chi-square (two degrees of freedom, each axis
/// over its sigma) is beyond this: the 3-sigma probability, 0.27 %.
inline constexpr double kPrincipalPointChiSquare = 11.83;
/// ... and when the turn it gives the result is beyond this many verification tolerances
/// (VerdictConfig::verify_rotation_deg): the tags' fit carries biases of its own beyond its sigma
/// (corner localisation under perspective), so the gate refuses what would make the result wrong,
/// not what a correct camera's fit scatters by.
inline constexpr double kPrincipalPointTurnTolerances = 2.0;
/// The turn compared with them is the measured one raised by this many of its sigmas: a shift
/// shown to be there can be that much larger than measured, and the extrinsic takes up the true
/// one (docs/performance-and-reliability.md, "Why the thresholds are where they are").
inline constexpr double kPrincipalPointTurnSigmas = 2.0;
/// A principal point whose sigma alone turns the result by more than this many of those turns is
/// refused too: the tags disagree with each other, as a wrong lens model makes them (the figures:
/// docs/performance-and-reliability.md, "Why the thresholds are where they are").
inline constexpr double kPrincipalPointSigmaTurns = 2.0;
/// ... when their corners also fit the lens model worse than this (RMS, px): three times the
/// corner precision the fit assumes (kCornerNoisePx). A short session's groups can scatter as
/// much with corners that fit, while a wrong lens leaves them misfit (the same section).
inline constexpr double kLensMisfitResidualPx = 3.0 * kCornerNoisePx;

/// The tags' shift against the intrinsic calibration's stated sigma and their own, blind spot
/// included (StatedPrincipalPointChiSquare with CornerBias::kAssumed), is refused beyond
/// kStatedPrincipalPointChiSquare (principal_point_check.hpp).

/// The tags disagree on the principal point and misfit the lens: a wrong lens model.
Reason CheckLensModel(const GateInput& in, std::string* detail);
/// The shift the tags agree on turns the result beyond the gate.
Reason CheckPrincipalPoint(const GateInput& in, std::string* detail);
/// The tags put the principal point beyond what the intrinsic calibration states.
Reason CheckStatedPrincipalPoint(const GateInput& in, std::string* detail);

}  // namespace calibd
