#pragma once
/// \file
/// `calibd-bench pipeline`: the time and CPU of every stage of a calibration, per LiDAR model, set
/// against the paper's figures (§IV-E: 18.7 s LiDAR detection, 4.93 s camera detection, 0.12 s grid
/// search, 1.25 s direct and 1.63 s indirect optimisation for 200 pairs on a 12-thread
/// i7-10750H) and our targets for a 2-core machine. Two parts per model:
///  - in process: the default simulated drive (3840x1920 images) detected frame by frame with the
///    real detectors (wall and process CPU time per frame), then the engine: the agent's default
///    configuration (grid search, direct optimisation with board-pose refinement, quality gates,
///    half-data re-solves), and the paper's two optimisers alone (direct Eq. 4, indirect);
///  - the real agent: the same drive published live over LCM to calibd-agent, timed from its start
///    to READY=1, from the last frame published to its result, with its CPU time and peak RSS.

#include <iosfwd>
#include <string>
#include <vector>

namespace calibd::bench {

struct PipelineBenchOptions {
  std::vector<std::string> lidars{"ot128", "m1", "falcon"};
  int frames = 200;  ///< frame pairs per drive
  unsigned long long seed = 1;
  std::string agent_path;  ///< calibd-agent for the live part ("" = skip it)
  std::string work_dir;    ///< keep the agent runs' logs and stores there ("" = temporary)
  std::string json_path;   ///< also write the figures as JSON
  /// Runs of each in-process engine configuration; the figures are those of the run with the
  /// median wall time (one run on a loaded machine is noise).
  int engine_runs = 5;
};

bool RunPipelineBench(const PipelineBenchOptions& options, std::ostream& out,
                      std::ostream* progress, std::string* error);

}  // namespace calibd::bench
