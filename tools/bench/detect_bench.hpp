#pragma once
/// \file
/// `calibd-bench detect`: runs the camera and LiDAR board detectors over simulated sessions and
/// reports precision, recall, a precision/recall curve over the match threshold, camera corner
/// error against the truth, and per-stage timing (paper §IV-B).

#include <iosfwd>
#include <string>
#include <vector>

namespace calibd::bench {

struct DetectBenchOptions {
  std::vector<std::string> lidars{"ot128", "m1", "falcon"};
  int frames = 200;  ///< frame pairs per session (default session: 200, 6-30 m)
  unsigned long long seed = 1;
  double match_radius_m = 0.2;  ///< a LiDAR detection is a true positive within this of a centre
  int min_truth_points = 10;    ///< a board counts as visible to the LiDAR with this many points
  std::string json_path;        ///< also write the figures as JSON
};

/// Runs the bench, printing tables to `out` and progress to `progress`. Returns false with
/// `error` when a session or detector could not be set up.
bool RunDetectBench(const DetectBenchOptions& options, std::ostream& out, std::ostream* progress,
                    std::string* error);

}  // namespace calibd::bench
