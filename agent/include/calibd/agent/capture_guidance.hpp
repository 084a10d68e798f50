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

namespace calibd {

/// A collecting session's coverage against its gates (SessionConfig).
struct CaptureCoverage {
  bool moving = true;          ///< moving session (the car drives) or static (boards move)
  uint32_t distance_bins = 0;  ///< bit b: a board seen in distance bin b
  int min_distance_bins = 3;   ///< gate: bins needed
  uint32_t image_cells = 0;    ///< bit c: a board centre seen in image cell c
  int min_image_cells = 4;     ///< gate: cells needed
  int frames_with_boards = 0;  ///< frame pairs with a board seen by both sensors
  int min_frames = 50;         ///< gate: frame pairs needed
  int target_frames = 200;     ///< collection ends at this many
  int boards = 0;              ///< board observations seen by both sensors
  int min_boards = 20;         ///< gate: boards needed
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
