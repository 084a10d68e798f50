#pragma once
/// \file
/// Capture guidance: what a collecting session still lacks, for the operator who places
/// the boards or drives the car. The same figures travel in the LCM status (as text), in DID
/// 0xFD06 (uds/did_codec.hpp, as numbers) and are turned into the same text by calibd-tester.
///
/// Distance bins: camera-to-board distance in [0, 8.5), [8.5, 15), [15, 25), [25, inf) m
/// (kDistanceBinEdgesM). Image cells: a kImageGridSide x kImageGridSide grid over the image,
/// cell index row * kImageGridSide + column, row 0 at the top.

#include <cstdint>
#include <string>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd {

/// The gates a collecting session ends on and solves with, defined once: the config's
/// agent.target_frames, agent.min_frames, agent.min_distance_bins, agent.min_image_cells
/// (AgentConfig) and engine.verdict.min_boards (SessionConfigFrom).
struct CoverageGates {
  int target_frames = 200;  ///< collection ends at this many frame pairs with boards
  /// Fewest frame pairs with boards a session solves with: fewer at the time limit fails it
  /// (too_few_frames); the coverage gates end collection only from this many on.
  int min_frames = 50;
  /// Fewest board observations a session solves with (too_few_boards): the engine's own.
  int min_boards = VerdictConfig{}.min_boards;
  int min_distance_bins = 3;  ///< boards seen in at least this many of the kDistanceBins bins
  int min_image_cells = 4;    ///< board centres in at least this many of the kImageCells cells
};

/// A collecting session's coverage against its gates.
struct CaptureCoverage {
  bool moving = true;          ///< moving session (the car drives) or static (boards move)
  uint32_t distance_bins = 0;  ///< bit b: a board seen in distance bin b
  uint32_t image_cells = 0;    ///< bit c: a board centre seen in image cell c
  int frames_with_boards = 0;  ///< frame pairs with a board seen by both sensors
  int boards = 0;              ///< board observations seen by both sensors
  CoverageGates gates;
};

/// Distance bins and image cells holding a board (bits outside the bins or the grid ignored).
int DistanceBinsSeen(const CaptureCoverage& coverage);
int ImageCellsSeen(const CaptureCoverage& coverage);

/// Operator names of the distance bins ("0-8.5 m" ...) and of the image quadrants ("top-left"...).
const char* DistanceBinName(int bin);
const char* ImageQuadrantName(int quadrant);

/// Appends to `out` what to do next: the distance bins and image quadrants still lacking boards
/// with the counts, or, once covered, how many frames or boards are still short. Appends
/// without allocating while `out` has about 200 characters of capacity.
void AppendCaptureGuidance(const CaptureCoverage& coverage, std::string* out);

}  // namespace calibd
