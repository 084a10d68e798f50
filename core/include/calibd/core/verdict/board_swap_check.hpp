#pragma once
/// \file
/// Boards of different sizes whose ids the config swaps (the tag the config gives board A printed
/// on board B). PnP on a tag of the wrong size puts it at the wrong distance (for the same
/// corners the distance grows with the tag size): board A's at s_A / s_B of the LiDAR's, board
/// B's at s_B / s_A. Two checks:
/// - when the grid search found nothing (the predicted boards miss the LiDAR's), the camera's
///   observations of each pair of boards of different sizes are re-posed as the other's (the
///   rotation kept, the translation scaled by the ratio of the sizes) and searched again;
/// - when it found a candidate, each board's camera distances against the LiDAR's under it are
///   nearer the swapped ratios than 1 for both boards of a pair.

#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/core/solve/grid_search.hpp"

namespace calibd {

struct BoardSwap {
  bool found = false;
  int board_a = -1, board_b = -1;  ///< indices into the configured boards
  GridSearchResult grid;           ///< the search with the two swapped (FindSwappedBoards)
  /// Median camera / LiDAR distance of each (FindSwapInDistances).
  double ratio_a = 1.0, ratio_b = 1.0;
};

/// Observations of a board needed for its median distance ratio.
inline constexpr int kMinSwapObservations = 5;

/// Tag sizes closer than this ratio are not tried: a swap of boards alike in size moves the
/// predicted boards too little to matter.
inline constexpr double kMinSwapSizeRatio = 1.05;

/// Tries every pair of configured boards whose tag sizes differ by kMinSwapSizeRatio or more
/// (both seen by the camera); the first pair whose swap lets the grid search succeed.
BoardSwap FindSwappedBoards(const GridSearchConfig& config, const RangeImage& projection,
                            const std::vector<BoardGeometry>& boards,
                            const SessionObservations& session, const Pose& T_camera_lidar_prior,
                            int max_frames);

/// The first pair of boards of tag sizes s_a, s_b differing by kMinSwapSizeRatio or more whose
/// median camera / LiDAR distance ratios (kMinSwapObservations each) are both nearer the swapped
/// ratios (s_a / s_b, s_b / s_a) than 1, and off 1 by more than half of them; their difference
/// too (a scale or distance error common to the boards leaves it).
BoardSwap FindSwapInDistances(const std::vector<BoardGeometry>& boards,
                              const std::vector<BoardDistance>& distances);

}  // namespace calibd
