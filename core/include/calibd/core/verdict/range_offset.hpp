#pragma once
/// \file
/// The LiDAR's range offset from the boards' in-plane centres. A range offset b moves every point
/// b along its ray: seen from ahead, the boards' plane distances take that for a translation, but
/// a board off to the side also has its centre moved by b within its plane, towards or away from
/// the LiDAR's axis, by how much depending on its direction and not on its distance. Fitted beside
/// a translation and a small rotation (which move the centres too, the rotation in proportion to
/// the distance) and the camera's scale over each board observation's three rows: its two in-plane
/// centre differences and its plane distance difference.

#include <limits>
#include <vector>

#include "calibd/core/session/board_distances.hpp"

namespace calibd {

struct RangeOffsetFit {
  bool fitted = false;    ///< enough rows, and the boards' directions determine the offset
  double offset_m = 0.0;  ///< b: the LiDAR's ranges are b longer than the camera's boards say
  double sigma_m = std::numeric_limits<double>::infinity();
  int blocks = 0;  ///< of the cluster-robust sigma (DistanceFit::blocks)
};

/// `rows` from BoardDistances with the boards' outlines (its in-plane centroids). `timed` adds the
/// residual time offset's term (n . v, board_motion.hpp) where the rows have velocities. Each kind
/// of row (along the board's x, its y, its normal) weighed by its own robust scatter, since a ring
/// LiDAR puts a board's vertical centre on its few rings; rows beyond kRangeOffsetOutlierSigmas
/// of theirs dropped (a person or a stand on a board). The sigma is the larger of the
/// least-squares one and the cluster-robust one over `min_cluster_blocks` blocks or more.
RangeOffsetFit FitRangeOffset(const std::vector<BoardDistance>& rows, bool timed,
                              int min_cluster_blocks);

inline constexpr double kRangeOffsetOutlierSigmas = 3.0;

}  // namespace calibd
