#pragma once
/// \file
/// The camera's scale against the LiDAR's ranges (beyond the paper): a tag size or focal length
/// off scales every PnP distance, which a translation cannot absorb. Measured over the boards'
/// distances (board_distances.hpp) after the solve; the engine corrects a small one and the
/// camera-scale gate refuses a large one.

#include <limits>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/session/board_observation.hpp"

namespace calibd {

/// Boards the camera-LiDAR scale fit needs (4 unknowns and a residual to measure), and the
/// spread of their distances, as a share of the farthest.
inline constexpr int kMinScaleBoards = 8;
inline constexpr double kMinScaleDistanceSpread = 0.3;
/// A scale error counts only beyond this many of its standard deviations.
inline constexpr double kScaleSigmas = 3.0;

/// Camera-LiDAR distance agreement (board_distances.hpp). Per board, the camera's distance to its
/// plane along the normal n (PnP) and the LiDAR's (its points under the solution). A tag size or
/// focal length wrong by a factor 1 + e makes every camera distance (1 + e) d; a translation
/// error c adds n . c; a LiDAR range offset b adds b (n . u), u the mean ray to the board's
/// points. The least-squares fit of d_camera - d_lidar = e d_camera + n . c + b (n . u) gives e
/// (what a translation cannot explain) and b, each with the larger of its least-squares and
/// cluster-robust sigmas; e without b where the boards leave b undetermined. The range offset
/// the quality figures report is the more precise of that b and the in-plane centres'
/// (FitRangeOffset, calibration_engine.cpp).
struct CameraScaleEstimate {
  /// Fitted over kMinScaleBoards boards or more whose distances spread by
  /// kMinScaleDistanceSpread of the farthest.
  bool scale_fitted = false;
  double scale = 0.0;  ///< e: the camera's distances are 1 + e times the LiDAR's
  double scale_sigma = std::numeric_limits<double>::infinity();
  bool range_offset_fitted = false;
  double range_offset_m = 0.0;
  double range_offset_sigma_m = std::numeric_limits<double>::infinity();
  /// The boards' mean distance: a scale e moves the translation by about e distance_m.
  double distance_m = 0.0;
};

/// The camera's scale is corrected only where it would move the translation by more than this
/// many verification tolerances (VerdictConfig::verify_translation_m; twice is where a result
/// becomes wrong): the fit also measures 0.1-0.3 % on correct cameras, PnP's bias on small far
/// tags and, in drives with a camera 40-100 ms late, scales that moved the corrected result
/// further from the truth (calibd-bench verdicts).
inline constexpr double kCorrectedScaleTolerances = 2.0;
/// The cluster-robust sigma counts over this many blocks of a board's frames (fewer, e.g. still
/// poses, leave only the least-squares one).
inline constexpr int kMinScaleClusterBlocks = 8;

/// From the set's BoardDistances under the solution (shared with EstimateTimeOffset).
CameraScaleEstimate EstimateCameraScale(const ObservationSet& set,
                                        const std::vector<BoardDistance>& distances);

/// The camera's view of a session whose patterns are `factor` times their configured size:
/// every PnP distance scales by it (PnP is scale-equivariant), so each observation's board
/// translation and velocity does, and the patterns' sizes in `boards` (the corners the board-pose
/// refinement fits). The boards' outlines, which the LiDAR measures, stay.
void ScaleCameraPatterns(double factor, std::vector<BoardGeometry>* boards, ObservationSet* set);

}  // namespace calibd
