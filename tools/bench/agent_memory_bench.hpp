#pragma once
/// \file
/// `calibd-bench agent-memory`: the agent's fixed memory, measured on the real process. One
/// simulated drive is published live over LCM UDP multicast in real time (10 Hz, inside a private
/// network namespace) once and then looped (capture times shifted, so time keeps going forward),
/// to the real calibd-agent running one session per run with the same config; the table gives
/// each session's peak RSS (the kernel's ru_maxrss of the agent process), frames received,
/// missing and dropped, frame pairs kept and used by the solve, and the verdict. A fixed-memory
/// agent has the same peak RSS for a 200-pair and a 2000-pair session (target: < 5% apart).

#include <iosfwd>
#include <string>
#include <vector>

namespace calibd::bench {

struct AgentMemoryBenchOptions {
  std::string agent_path;         ///< calibd-agent to run
  std::string lidar = "ot128";    ///< LiDAR model of the simulated drive
  int frames = 200;               ///< frame pairs of the drive (published once per loop)
  std::vector<int> loops{1, 10};  ///< one session per entry: the drive published this many times
  unsigned long long seed = 1;
  std::string work_dir;   ///< where the log, configs and stores go ("" = a temporary directory)
  std::string json_path;  ///< also write the figures as JSON
};

bool RunAgentMemoryBench(const AgentMemoryBenchOptions& options, std::ostream& out,
                         std::ostream* progress, std::string* error);

}  // namespace calibd::bench
