// calibd-bench: evaluation and speed benchmarks that print tables (and JSON with --json).

#include <cstdlib>
#include <iostream>
#include <sstream>
#include <string>

#include "detect_bench.hpp"

namespace {

constexpr const char* kHelp =
    R"(calibd-bench: evaluation and speed benchmarks on simulated sessions.

Usage: calibd-bench detect [options]

detect   camera and LiDAR board detection over the default simulated session (3 boards, clutter,
         driving 6-30 m): precision, recall (a LiDAR detection is a true positive within 0.2 m of
         a true board centre, paper IV-B), a precision/recall curve over thresholds 0.70-0.99,
         camera corner error against the truth, and median/p95 time per frame of each stage.
  --lidar LIST        comma-separated models (default ot128,m1,falcon)
  --frames N          frame pairs per session (default 200)
  --seed N            simulation seed (default 1)
  --json FILE         also write the figures as JSON

Exit codes: 0 done, 1 failed, 2 bad option.
)";

bool ParseInt(const std::string& s, long long lo, long long hi, long long* v) {
  char* end = nullptr;
  const long long x = std::strtoll(s.c_str(), &end, 10);
  if (s.empty() || *end != '\0' || x < lo || x > hi) return false;
  *v = x;
  return true;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2 || std::string(argv[1]) == "--help" || std::string(argv[1]) == "-h") {
    std::cout << kHelp;
    return argc < 2 ? 2 : 0;
  }
  const std::string command = argv[1];
  if (command != "detect") {
    std::cerr << "calibd-bench: unknown command '" << command << "' (see --help)\n";
    return 2;
  }
  calibd::bench::DetectBenchOptions o;
  for (int i = 2; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::cout << kHelp;
      return 0;
    }
    if (i + 1 >= argc) {
      std::cerr << "calibd-bench: option " << arg << " needs a value (see --help)\n";
      return 2;
    }
    const std::string value = argv[++i];
    long long n = 0;
    if (arg == "--lidar") {
      o.lidars.clear();
      std::stringstream ss(value);
      std::string item;
      while (std::getline(ss, item, ',')) {
        if (item != "ot128" && item != "m1" && item != "falcon") {
          std::cerr << "calibd-bench: unknown LiDAR model '" << item
                    << "' in --lidar (expected ot128, m1, falcon)\n";
          return 2;
        }
        o.lidars.push_back(item);
      }
    } else if (arg == "--frames" && ParseInt(value, 1, 100000, &n)) {
      o.frames = static_cast<int>(n);
    } else if (arg == "--seed" && ParseInt(value, 0, 1LL << 53, &n)) {
      o.seed = static_cast<unsigned long long>(n);
    } else if (arg == "--json") {
      o.json_path = value;
    } else {
      std::cerr << "calibd-bench: bad option or value '" << arg << " " << value
                << "' (see --help)\n";
      return 2;
    }
  }
  std::string error;
  if (!calibd::bench::RunDetectBench(o, std::cout, &std::cerr, &error)) {
    std::cerr << "calibd-bench: " << error << "\n";
    return 1;
  }
  return 0;
}
