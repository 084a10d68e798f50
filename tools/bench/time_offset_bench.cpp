#include "time_offset_bench.hpp"

#include <cmath>
#include <nlohmann/json.hpp>

#include "calib_experiments.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "quality_json.hpp"
#include "seed_kind.hpp"

namespace calibd::bench {

namespace {

/// How the recording stamps its pairs.
enum class Stamps { kCameraAtTrigger, kOneTimePerPair };

struct Drive {
  std::string lidar;
  Stamps stamps = Stamps::kCameraAtTrigger;
  double delay_ms = 0.0;
  bool one_way = false;  ///< only towards the boards (the first half of the default drive)
};

struct DriveResult {
  Drive drive;
  double true_offset_ms = 0.0;
  ScoredRun run;
  std::string verdict, reason;
  std::string error;
};

const char* StampsName(Stamps s) {
  return s == Stamps::kCameraAtTrigger ? "camera at its trigger" : "one time per pair";
}

bool RunDrive(const Drive& d, unsigned long long seed, DriveResult* out) {
  out->drive = d;
  sim::SessionOptions options;  // the default drive: 3 boards, 6-30 m and back, 20 s at 10 Hz
  options.seed = seed;
  options.lidar_model = d.lidar;
  options.camera_delay_us = std::llround(d.delay_ms * 1e3);
  if (d.one_way) options.trajectory.duration_s /= 2.0;
  RecordingFaults faults;
  if (d.stamps == Stamps::kCameraAtTrigger)
    faults.camera_stamp_shift_us = -options.camera_delay_us;
  else
    faults.one_time_per_pair = true;
  RecordedDrive drive;
  if (!RecordDrive(options, &drive, &out->error, LidarDetectorConfig{}, nullptr, faults))
    return false;
  // The true offset: the camera's capture time minus its stamp (for one time per pair, the
  // sweep's start), the same in every frame.
  out->true_offset_ms = d.delay_ms;
  if (d.stamps == Stamps::kOneTimePerPair) {
    sim::SessionSimulator sim;  // the camera triggers this long after the sweep's start
    if (!sim.Init(options, &out->error)) return false;
    out->true_offset_ms += static_cast<double>(sim.camera_phase_us()) * 1e-3;
  }
  LidarKind kind;
  LidarKindFromName(d.lidar, &kind, nullptr);
  const RangeImage projection = SessionProjection(MakeLidarModel(kind));
  EngineConfig engine;
  engine.direct.threads = 1;
  out->run = RunEngine(drive.config, drive.observations, projection, engine, drive.T_camera_lidar);
  return true;
}

std::string Fixed(double v, int decimals) { return FixedDecimal(v, decimals); }

}  // namespace

bool RunTimeOffsetBench(const TimeOffsetBenchOptions& o, std::ostream& out, std::ostream* progress,
                        std::string* error) {
  std::vector<Drive> drives;
  for (const std::string& lidar : o.lidars) {
    for (double ms : {0.0, 10.0, 30.0, 60.0, 100.0})
      drives.push_back({lidar, Stamps::kCameraAtTrigger, ms, false});
    for (double ms : {0.0, 30.0}) drives.push_back({lidar, Stamps::kOneTimePerPair, ms, false});
    drives.push_back({lidar, Stamps::kCameraAtTrigger, 30.0, true});
  }
  std::vector<DriveResult> results(drives.size());
  ParallelTasks(
      static_cast<int>(drives.size()), o.threads,
      [&](int k) {
        RunDrive(drives[static_cast<size_t>(k)], o.seed, &results[static_cast<size_t>(k)]);
      },
      progress, "calibd-bench time-offset", "drives");

  out << "Camera time offset, estimated from the boards' motion: the default drive (3 boards, "
         "6-30 m and back, 20 s at 10 Hz; one way: only towards the boards), "
      << SeedLabel(o.seed) << ".\n\n"
      << "| LiDAR | stamps | camera late | true offset | estimated (sigma) | corrected for | "
         "error of the estimate | rotation error | translation error | verdict |\n"
      << "|---|---|---|---|---|---|---|---|---|---|\n";
  nlohmann::json doc;
  doc["seed"] = o.seed;
  doc["seed_kind"] = SeedKind(o.seed);
  for (const DriveResult& r : results) {
    if (!r.error.empty()) {
      if (error) *error = r.drive.lidar + ": " + r.error;
      return false;
    }
    const QualityFigures& q = r.run.quality;
    const bool fitted = r.run.has_estimate && q.time_offset_fitted;
    out << "| " << r.drive.lidar << " | " << StampsName(r.drive.stamps)
        << (r.drive.one_way ? ", one way" : "") << " | " << Fixed(r.drive.delay_ms, 0) << " ms | "
        << Fixed(r.true_offset_ms, 1) << " ms | "
        << (fitted ? Fixed(q.time_offset_s * 1e3, 1) + " ms (" +
                         Fixed(q.time_offset_sigma_s * 1e3, 1) + ")"
                   : std::string("not fitted"))
        << " | " << Fixed(q.time_offset_corrected_s * 1e3, 1) << " ms | "
        << (fitted ? Fixed(std::fabs(q.time_offset_s * 1e3 - r.true_offset_ms), 1) + " ms"
                   : std::string("-"))
        << " | "
        << (r.run.has_estimate ? Fixed(r.run.rotation_error_deg, 3) + " deg" : std::string("-"))
        << " | "
        << (r.run.has_estimate ? Fixed(r.run.translation_error_m * 100.0, 2) + " cm"
                               : std::string("-"))
        << " | " << r.run.verdict << (r.run.reason.empty() ? "" : " (" + r.run.reason + ")")
        << " |\n";
    nlohmann::json j;
    j["lidar"] = r.drive.lidar;
    j["stamps"] = StampsName(r.drive.stamps);
    j["one_way"] = r.drive.one_way;
    j["camera_late_ms"] = r.drive.delay_ms;
    j["true_offset_ms"] = r.true_offset_ms;
    j["verdict"] = r.run.verdict;
    j["reason"] = r.run.reason;
    if (r.run.has_estimate) {
      j["rotation_error_deg"] = r.run.rotation_error_deg;
      j["translation_error_m"] = r.run.translation_error_m;
      j["quality"] = QualityJson(q);
    }
    doc["drives"].push_back(j);
  }
  if (!o.json_path.empty() && !WriteFileAtomic(o.json_path, doc.dump(2) + "\n", error))
    return false;
  return true;
}

}  // namespace calibd::bench
