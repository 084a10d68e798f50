#pragma once
/// \file
/// calibd-bench's command line: `calibd-bench <command> [options]`, each command's options read
/// by the tools' shared parser (tools/common/command_line.hpp) into its benchmark's options.

#include <string>

#include "agent_memory_bench.hpp"
#include "calib_bench.hpp"
#include "detect_bench.hpp"
#include "pipeline_bench.hpp"
#include "recordings_bench.hpp"
#include "resolution_bench.hpp"
#include "soak_bench.hpp"
#include "time_offset_bench.hpp"
#include "verdicts_bench.hpp"

namespace calibd::bench {

/// The command and its options; only the command's own options are read, the rest keep what
/// they held before the parse (the defaults, and the agent's and simulator's paths).
struct BenchCommandLine {
  std::string command;  ///< detect, calib, agent-memory, pipeline, resolution, soak, ...
  bool help = false;    ///< --help after the command: nothing else was checked
  DetectBenchOptions detect;
  CalibBenchOptions calib;
  AgentMemoryBenchOptions memory;
  PipelineBenchOptions pipeline;
  ResolutionBenchOptions resolution;
  SoakBenchOptions soak;
  RecordingsBenchOptions recordings;
  VerdictsBenchOptions verdicts;
  TimeOffsetBenchOptions time_offset;
};

/// Reads argv (argv[1]: the command) into `b`. False with `error` (one line naming the option and
/// its value, without the program's name) on an unknown command, option or a bad value.
bool ParseBenchCommandLine(int argc, char** argv, BenchCommandLine* b, std::string* error);

}  // namespace calibd::bench
