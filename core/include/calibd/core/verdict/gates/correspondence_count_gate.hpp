#pragma once
/// \file
/// The least data the engine solves with, counted before the solve (and again once boards that do
/// not fit are dropped): `too_few_frames`, `too_few_boards`.

#include <string>

#include "calibd/core/verdict/quality_figures.hpp"
#include "calibd/core/verdict/reason.hpp"

namespace calibd {

struct CorrespondenceCountConfig {
  /// The verdict rests on the evidence (the formal sigmas, the plane conditioning, the half-data
  /// spread, the residuals), not on counts: a dozen well-spread still poses of one board can pass,
  /// two hundred frames of one board far away cannot. A board correspondence fixes a plane; six
  /// leave each half of the half-data re-solves about three, the fewest non-parallel planes that
  /// fix all six degrees of freedom. Frames add nothing by themselves: one shot of a wall of
  /// boards counts like six shots of one.
  int min_frames = 1;  ///< frame pairs with at least one correspondence
  int min_boards = 6;  ///< board correspondences
};

/// A rejection when too few frame pairs or boards have a correspondence (QualityFigures'
/// frames_used, boards_used), `after` telling when they were counted; kNone otherwise.
Reason TooFewCorrespondences(const QualityFigures& q, const CorrespondenceCountConfig& c,
                             const std::string& after, std::string* detail);

}  // namespace calibd
