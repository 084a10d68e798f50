#include "resolution_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "session.hpp"

namespace calibd::bench {

namespace {
// CPU time of this thread, ms: on a loaded machine wall time also counts the waits for a core.
double ThreadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) * 1e-6;
}
}  // namespace

int RunResolutionBench(const ResolutionBenchOptions& options) {
  const int repeat = options.repeat;
  std::printf("%-7s %8s %9s %9s %9s %9s %9s %9s %9s %9s %s\n", "lidar", "points", "az [deg]",
              "el [deg]", "model az", "model el", "h spread", "h frac", "median ms", "p95 ms",
              "pattern");
  for (const LidarKind kind : SimulatedLidarKinds()) {
    const LidarModel named = MakeLidarModel(kind);
    const char* lidar = named.name.c_str();
    sim::SessionOptions o;
    o.lidar_model = lidar;
    o.trajectory.mode = "static";
    o.trajectory.static_distance_m = 12.0;
    sim::SessionSimulator s;
    std::string error;
    if (!s.Init(o, &error)) {
      std::fprintf(stderr, "calibd-bench resolution: %s\n", error.c_str());
      return 1;
    }
    sim::LidarScan scan;
    sim::FrameTruth truth;
    s.SimulateFrame(0, nullptr, &scan, &truth);
    const PointCloudView view{scan.x.data(), scan.y.data(), scan.z.data(), nullptr, scan.size()};
    LidarResolutionEstimate est = EstimateLidarResolution(&view, 1);  // warm-up
    std::vector<double> ms, cpu;
    for (int r = 0; r < repeat; ++r) {
      const double c0 = ThreadCpuMs();
      const auto t0 = std::chrono::steady_clock::now();
      est = EstimateLidarResolution(&view, 1);
      ms.push_back(MsSince(t0));
      cpu.push_back(ThreadCpuMs() - c0);
    }
    std::sort(ms.begin(), ms.end());
    std::sort(cpu.begin(), cpu.end());
    if (!est.ok) {
      std::fprintf(stderr, "calibd-bench resolution: %s: %s\n", lidar, est.error.c_str());
      return 1;
    }
    std::printf(
        "%-7s %8zu %9.4f %9.4f %9.4f %9.4f %9.3f %9.3f %9.2f %9.2f %s\n", lidar, scan.size(),
        est.azimuth_resolution_deg, est.elevation_resolution_deg, named.azimuth_resolution_deg,
        named.has_rings
            ? std::abs(named.ring_elevation_deg.front() - named.ring_elevation_deg.back()) /
                  static_cast<double>(named.ring_elevation_deg.size() - 1)
            : named.elevation_resolution_deg,
        est.horizontal_gap_spread, est.horizontal_cluster_fraction, ms[ms.size() / 2],
        ms[std::min(ms.size() - 1, ms.size() * 95 / 100)], est.irregular ? "irregular" : "lines");
  }
  return 0;
}

}  // namespace calibd::bench
