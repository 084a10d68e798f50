#pragma once
/// \file
/// Flatness gate (QualityFigures::board_bend_m, board_flatness.hpp): a board whose face bends more
/// than kMaxBoardBendM at its centre line, beyond kBoardBendSigmas of its sigma, is
/// `board_not_flat`. Asked first: a bent board also shows as a range offset, a scale, a lens
/// misfit or scatter.

#include "calibd/core/verdict/gate.hpp"

namespace calibd {

/// The operator guide asks for 2 mm, within which the bend is measured on clean boards: the gate
/// leaves room above it. A property of the boards, not a tolerance of the result: not
/// configurable.
inline constexpr double kMaxBoardBendM = 0.005;
inline constexpr double kBoardBendSigmas = 4.0;

Reason CheckBoardFlatness(const GateInput& in, std::string* detail);

}  // namespace calibd
