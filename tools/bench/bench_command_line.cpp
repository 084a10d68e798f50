#include "bench_command_line.hpp"

#include <map>
#include <utility>
#include <vector>

#include "calibd/core/lidar/lidar_model.hpp"
#include "command_line.hpp"

namespace calibd::bench {

namespace {

using tools::CommandLine;

// Refuses, naming the option, a model the simulator has no scan pattern for.
bool SimulatedLidar(CommandLine& line, const std::string& name) {
  LidarKind kind;
  if (LidarKindFromName(name, &kind, nullptr) && kind != LidarKind::kGeneric) return true;
  line.Error("unknown LiDAR model '" + name + "' in " + line.arg() + " (expected any of " +
             LidarModelNames() + " but generic)");
  return false;
}

// The current option's comma-separated LiDAR models.
bool Lidars(CommandLine& line, std::vector<std::string>* lidars) {
  std::string text;
  if (!line.Value(&text)) return false;
  std::vector<std::string> names = tools::SplitList(text);
  for (const std::string& name : names)
    if (!SimulatedLidar(line, name)) return false;
  *lidars = std::move(names);
  return true;
}

bool Seed(CommandLine& line, unsigned long long* seed) {
  long n = 0;
  if (!line.Integer(0, 1L << 53, &n)) return false;
  *seed = static_cast<unsigned long long>(n);
  return true;
}

// Each command's options: true when the current argument is one of them (its value read, or
// the error set in `line`), false for an option the command does not have.

// detect's, calib's and pipeline's: the simulated drives.
bool DriveOption(CommandLine& line, std::vector<std::string>* lidars, int* frames,
                 unsigned long long* seed, std::string* json_path) {
  if (line.Is("--lidar"))
    Lidars(line, lidars);
  else if (line.Is("--frames"))
    line.Integer(1, 100000, frames);
  else if (line.Is("--seed"))
    Seed(line, seed);
  else if (line.Is("--json"))
    line.Value(json_path);
  else
    return false;
  return true;
}

bool DetectOption(CommandLine& line, DetectBenchOptions* d) {
  return DriveOption(line, &d->lidars, &d->frames, &d->seed, &d->json_path);
}

bool CalibOption(CommandLine& line, CalibBenchOptions* c) {
  if (line.Is("--trajectories"))
    line.Integer(1, 1000, &c->trajectories);
  else if (line.Is("--trials"))
    line.Integer(0, 100000, &c->trials);
  else
    return DriveOption(line, &c->lidars, &c->frames, &c->seed, &c->json_path);
  return true;
}

bool PipelineOption(CommandLine& line, PipelineBenchOptions* p) {
  std::string agent;
  if (line.Is("--agent")) {
    if (line.Value(&agent)) p->agent_path = agent == "none" ? "" : agent;
  } else if (line.Is("--engine-runs")) {
    line.Integer(1, 1000, &p->engine_runs);
  } else if (line.Is("--work-dir")) {
    line.Value(&p->work_dir);
  } else {
    return DriveOption(line, &p->lidars, &p->frames, &p->seed, &p->json_path);
  }
  return true;
}

bool AgentMemoryOption(CommandLine& line, AgentMemoryBenchOptions* m) {
  std::string lidar;
  std::vector<long> loops;
  if (line.Is("--agent")) {
    line.Value(&m->agent_path);
  } else if (line.Is("--lidar")) {
    if (line.Value(&lidar) && SimulatedLidar(line, lidar)) m->lidar = lidar;
  } else if (line.Is("--frames")) {
    line.Integer(10, 100000, &m->frames);
  } else if (line.Is("--seed")) {
    Seed(line, &m->seed);
  } else if (line.Is("--work-dir")) {
    line.Value(&m->work_dir);
  } else if (line.Is("--json")) {
    line.Value(&m->json_path);
  } else if (line.Is("--loops")) {
    if (line.Integers(tools::Count{1}, 1, 1000, &loops))
      m->loops.assign(loops.begin(), loops.end());
  } else {
    return false;
  }
  return true;
}

bool ResolutionOption(CommandLine& line, ResolutionBenchOptions* r) {
  if (!line.Is("--repeat")) return false;
  line.Integer(1, 10000, &r->repeat);
  return true;
}

bool SoakOption(CommandLine& line, SoakBenchOptions* k) {
  if (line.Is("--minutes"))
    line.Number(0.01, 10000, &k->minutes);
  else if (line.Is("--drive"))
    line.Value(&k->drive_log);
  else if (line.Is("--calib-yaml"))
    line.Value(&k->calib_yaml);
  else if (line.Is("--agent"))
    line.Value(&k->agent_path);
  else if (line.Is("--sim"))
    line.Value(&k->sim_path);
  else if (line.Is("--interface"))
    line.Value(&k->interface);
  else if (line.Is("--lcm-url"))
    line.Value(&k->lcm_url);
  else if (line.Is("--speed"))
    line.Number(0.01, 100, &k->speed);
  else if (line.Is("--min-frames"))
    line.Integer(1, 100000, &k->min_frames);
  else if (line.Is("--min-distance-bins"))
    line.Integer(0, 4, &k->min_distance_bins);
  else if (line.Is("--max-translation-bound-m"))
    line.Number(0.001, 10, &k->max_translation_bound_m);
  else if (line.Is("--max-rotation-bound-deg"))
    line.Number(0.001, 10, &k->max_rotation_bound_deg);
  else if (line.Is("--p2-ms"))
    line.Integer(1, 60000, &k->p2_ms);
  else if (line.Is("--max-rss-growth-mb"))
    line.Number(0, 100000, &k->max_rss_growth_mb);
  else if (line.Is("--work-dir"))
    line.Value(&k->work_dir);
  else if (line.Is("--json"))
    line.Value(&k->json_path);
  else
    return false;
  return true;
}

bool RecordingsOption(CommandLine& line, RecordingsBenchOptions* r) {
  std::string scenarios;
  if (line.Is("--scenario")) {
    if (line.Value(&scenarios))  // each --scenario adds to the list
      for (const std::string& name : tools::SplitList(scenarios)) r->scenarios.push_back(name);
  } else if (line.Is("--seed")) {
    Seed(line, &r->seed);
  } else if (line.Is("--trials")) {
    line.Integer(0, 100000, &r->grid_trials);
  } else if (line.Is("--extract-planes")) {
    line.OnOff(&r->extract_planes);
  } else if (line.Is("--json")) {
    line.Value(&r->json_path);
  } else {
    return false;
  }
  return true;
}

bool VerdictsOption(CommandLine& line, VerdictsBenchOptions* v) {
  std::vector<long> only;
  if (line.Is("--quick")) {
    v->quick = true;
  } else if (line.Is("--sessions")) {
    line.Integer(1, 1000000, &v->sessions);
  } else if (line.Is("--seed")) {
    Seed(line, &v->seed);
  } else if (line.Is("--threads")) {
    line.Integer(1, 64, &v->threads);
  } else if (line.Is("--only")) {  // each --only adds to the list
    if (line.Integers(tools::Count{1}, 0, 1000000, &only))
      v->only.insert(v->only.end(), only.begin(), only.end());
  } else if (line.Is("--faults")) {
    std::string text;
    if (!line.Value(&text)) return true;
    std::vector<std::string> names = tools::SplitList(text);
    for (const std::string& name : names) {
      if (IsVerdictFault(name)) continue;
      line.Error("unknown fault '" + name + "' in " + line.arg() + " (expected any of " +
                 VerdictFaultNames() + ")");
      return true;
    }
    v->faults = std::move(names);
  } else if (line.Is("--unshared")) {
    v->share_recordings = false;
  } else if (line.Is("--json")) {
    line.Value(&v->json_path);
  } else {
    return false;
  }
  return true;
}

bool TimeOffsetOption(CommandLine& line, TimeOffsetBenchOptions* t) {
  if (line.Is("--lidar"))
    Lidars(line, &t->lidars);
  else if (line.Is("--seed"))
    Seed(line, &t->seed);
  else if (line.Is("--threads"))
    line.Integer(1, 64, &t->threads);
  else if (line.Is("--json"))
    line.Value(&t->json_path);
  else
    return false;
  return true;
}

// Each command with the reader of its options.
using OptionReader = bool (*)(CommandLine&, BenchCommandLine*);
const std::map<std::string, OptionReader>& Commands() {
  static const std::map<std::string, OptionReader> commands = {
      {"detect", [](CommandLine& l, BenchCommandLine* b) { return DetectOption(l, &b->detect); }},
      {"calib", [](CommandLine& l, BenchCommandLine* b) { return CalibOption(l, &b->calib); }},
      {"agent-memory",
       [](CommandLine& l, BenchCommandLine* b) { return AgentMemoryOption(l, &b->memory); }},
      {"pipeline",
       [](CommandLine& l, BenchCommandLine* b) { return PipelineOption(l, &b->pipeline); }},
      {"resolution",
       [](CommandLine& l, BenchCommandLine* b) { return ResolutionOption(l, &b->resolution); }},
      {"soak", [](CommandLine& l, BenchCommandLine* b) { return SoakOption(l, &b->soak); }},
      {"recordings",
       [](CommandLine& l, BenchCommandLine* b) { return RecordingsOption(l, &b->recordings); }},
      {"verdicts",
       [](CommandLine& l, BenchCommandLine* b) { return VerdictsOption(l, &b->verdicts); }},
      {"time-offset",
       [](CommandLine& l, BenchCommandLine* b) { return TimeOffsetOption(l, &b->time_offset); }},
  };
  return commands;
}

}  // namespace

bool ParseBenchCommandLine(int argc, char** argv, BenchCommandLine* b, std::string* error) {
  b->command = argc > 1 ? argv[1] : "";
  const auto command = Commands().find(b->command);
  if (command == Commands().end()) {
    *error = "unknown command '" + b->command + "' (see --help)";
    return false;
  }
  CommandLine line("calibd-bench", argc - 1, argv + 1);  // the options after the command
  while (line.Next()) {
    if (line.Is("--help") || line.Is("-h")) {
      b->help = true;
      return true;
    }
    if (!command->second(line, b)) line.Unknown();
  }
  if (!line.failed() && b->command == "soak" &&
      (b->soak.drive_log.empty() || b->soak.calib_yaml.empty()))
    line.Error("soak needs --drive LOG and --calib-yaml FILE (see --help)");
  *error = line.error();
  return !line.failed();
}

}  // namespace calibd::bench
