#pragma once
/// \file
/// The frame pairs of a session in capture order, each once. The order a session holds them in
/// is their arrival order, which a log written out of order or a replay that sends pairs twice
/// does not keep; motion compensation finds a board's neighbours in time among the adjacent
/// frames, and a pair counted twice would weigh double and sit in both halves of a half-data
/// re-solve.

#include <vector>

#include "calibd/core/session/session_observations.hpp"

namespace calibd {

/// The frames of `s` in capture order, each once; empty when `s` is already so, or carries no
/// capture times (pairs by file name) to order by. `out_of_order` counts the pairs that arrived
/// earlier than one captured before them, `duplicates` those that arrived again.
std::vector<int> CaptureOrder(const SessionObservations& s, int* out_of_order, int* duplicates);

}  // namespace calibd
