#pragma once
/// \file
/// Runs a whole simulated session to its outputs: the LCM log, the truth JSON, the user config and
/// an optional overlay picture. Shared by calibd-sim and the tests.

#include <iosfwd>
#include <string>
#include <vector>

#include "session.hpp"

namespace calibd::sim {

struct SimOutputs {
  std::string log_path;  ///< LCM log ("" = none; then folder_path is required)
  /// A folder of recorded frames as other tools write them ("" = none): NNNNNN.pcd (binary PCD
  /// with x y z intensity, ring for sensors with rings, t) and NNNNNN.png (or .jpg with the jpeg
  /// image encoding), and frames.csv with their capture times unless folder_without_times (the
  /// pairs then go by name, as drivers/recorded_folder.hpp reads them).
  std::string folder_path;
  bool folder_without_times = false;
  std::string truth_path;    ///< ground-truth JSON ("" = none)
  std::string config_path;   ///< user calibration config YAML ("" = none)
  std::string overlay_path;  ///< PNG of one frame with projected LiDAR points ("" = none)
  int overlay_frame = 0;
  double overlay_scale = 0.5;
};

/// What was made, per frame.
struct SimFrameSummary {
  double time_s = 0.0;
  double distance_m = 0.0;  ///< LiDAR to the board line
  int lidar_points = 0;
  int boards_in_camera = 0;  ///< tags fully in the image
  int boards_in_lidar = 0;   ///< boards with >= 10 LiDAR points
  int board_points = 0;      ///< LiDAR points on boards
};

struct SimSummary {
  int64_t events_written = 0;
  int64_t log_bytes = 0;
  std::vector<SimFrameSummary> frames;
};

/// Simulates every frame and writes the outputs. Progress lines go to `progress` (may be null).
bool RunSimulation(const SessionOptions& options, const SimOutputs& outputs, SimSummary* summary,
                   std::ostream* progress, std::string* error);

/// Human-readable summary table (every `every`-th frame, then totals).
void PrintSummary(const SimSummary& summary, int every, std::ostream& out);

}  // namespace calibd::sim
