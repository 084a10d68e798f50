#include "recordings_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <nlohmann/json.hpp>

#include "calib_experiments.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "seed_kind.hpp"

namespace calibd::bench {

namespace {

// One kind of recording a user brings, and what calibd must make of it.
struct Scenario {
  const char* name;
  const char* what;  // for the table's legend
  const char* lidar;
  int poses;
  double min_distance_m, max_distance_m;
  double board_width_m, board_height_m;
  bool checkerboard;  // else an AprilTag filling 78% of the board
  bool fisheye;
  bool generic;  // the config says `lidar.model: generic`: the detector's model is estimated
  // Targets: LiDAR board recall and precision, and the error of an `updated`.
  double min_recall, min_precision;
  double max_rotation_deg, max_translation_m;
  /// Frame pairs per pose, a sweep apart: a stream recorded while the board stood still (the
  /// LiDAR recall then counts poses whose board was found in any of their sweeps).
  int frames_per_pose = 1;
};

constexpr Scenario kScenarios[] = {
    {"vlp16-checker-fisheye", "VLP-16, fisheye, 0.8 x 1.0 m checkerboard, 1.5-5 m, 40 poses",
     "vlp16", 40, 1.5, 5.0, 0.8, 1.0, true, true, false, 0.95, 0.99, 0.15, 0.015},
    {"vlp16-tag", "VLP-16, pinhole, 0.9 m AprilTag board, 3-10 m, 12 poses", "vlp16", 12, 3.0, 10.0,
     0.9, 0.9, false, false, false, 0.0, 0.99, 0.3, 0.02},
    {"avia", "Livox-Avia-like rosette, pinhole, 0.9 m tag board, 1.5-8 m, 30 poses", "avia", 30,
     1.5, 8.0, 0.9, 0.9, false, false, false, 0.95, 0.99, 0.1, 0.01},
    {"avia-generic",
     "the avia scenario with lidar.model generic (bins and pattern estimated from 3 sweeps)",
     "avia", 30, 1.5, 8.0, 0.9, 0.9, false, false, true, 0.95, 0.99, 0.1, 0.01},
    {"mid360", "Livox-Mid-360-like, pinhole, 0.9 m tag board, 1.5-6 m, 30 poses", "mid360", 30, 1.5,
     6.0, 0.9, 0.9, false, false, false, 0.95, 0.99, 0.3, 0.03},
    {"avia-stream",
     "the avia scenario recorded as a stream: 10 sweeps (1 s at 10 Hz) per pose, as Livox users "
     "record",
     "avia", 30, 1.5, 8.0, 0.9, 0.9, false, false, false, 0.95, 0.99, 0.1, 0.01, 10},
    {"mid360-stream", "the mid360 scenario recorded as a stream: 10 sweeps per pose", "mid360", 30,
     1.5, 6.0, 0.9, 0.9, false, false, false, 0.95, 0.99, 0.3, 0.03, 10},
    {"vlp32c", "VLP-32C, pinhole, 0.9 m tag board, 1.5-10 m, 20 poses", "vlp32c", 20, 1.5, 10.0,
     0.9, 0.9, false, false, false, 0.95, 0.99, 0.3, 0.03},
    {"os1-64", "Ouster OS1-64, pinhole, 0.9 m tag board, 1.5-10 m, 20 poses", "os1-64", 20, 1.5,
     10.0, 0.9, 0.9, false, false, false, 0.95, 0.99, 0.3, 0.03},
};

sim::SessionOptions ScenarioSession(const Scenario& s, unsigned long long seed) {
  sim::SessionOptions o;
  o.seed = seed;
  o.lidar_model = s.lidar;
  o.trajectory.mode = "stills";
  o.trajectory.rate_hz = 0.5;  // people move the board between shots: 2 s apart
  o.trajectory.duration_s = s.poses / o.trajectory.rate_hz;
  o.stills.frames_per_pose = s.frames_per_pose;
  o.stills.min_distance_m = s.min_distance_m;
  o.stills.max_distance_m = s.max_distance_m;
  o.workshop.num_boards = 1;
  o.workshop.board_width_m = s.board_width_m;
  o.workshop.board_height_m = s.board_height_m;
  o.workshop.tag_size_m = 0.78 * std::min(s.board_width_m, s.board_height_m);
  if (s.checkerboard) {
    // 8 x 10 squares of 8 cm (7 x 9 inner corners) on the 0.8 x 1.0 m board.
    o.workshop.checkerboard_board = 0;
    o.workshop.checker_inner_rows = 9;
    o.workshop.checker_inner_cols = 7;
    o.workshop.checker_square_m = 0.08;
  }
  o.camera = ScenarioCamera(s.fisheye);
  // A nominal prior from the drawings: 8 deg and 15 cm off.
  o.prior_rot_deg = 8.0;
  o.prior_trans_m = 0.15;
  return o;
}

// The generic model calibd-calibrate would use: estimated from the session's first three sweeps
// without their ring field; `note` describes it (with the estimate's warning, if any).
bool EstimateGenericModel(const sim::SessionOptions& options, LidarModel* model, std::string* note,
                          std::string* error) {
  sim::SessionSimulator session;
  if (!session.Init(options, error)) return false;
  std::vector<sim::LidarScan> scans(3);
  std::vector<PointCloudView> views;
  sim::FrameTruth truth;
  for (size_t k = 0; k < scans.size(); ++k) {
    session.SimulateFrame(static_cast<int>(k), nullptr, &scans[k], &truth);
    views.push_back(PointCloudView{scans[k].x.data(), scans[k].y.data(), scans[k].z.data(), nullptr,
                                   scans[k].size()});
  }
  const LidarResolutionEstimate estimate = EstimateLidarResolution(views.data(), views.size());
  if (!estimate.ok) {
    if (error) *error = "generic LiDAR estimate: " + estimate.error;
    return false;
  }
  if (!MakeGenericLidarModel(GenericLidarConfig{}, &estimate, model, error)) return false;
  *note = DescribeGenericLidar(*model, &estimate);
  return true;
}

// Share of the poses' visible boards found in at least one sweep of their pose.
double PoseRecall(const RecordedDrive& drive, int frames_per_pose) {
  int found = 0, visible = 0;
  for (size_t first = 0; first < drive.lidar_found_boards.size();
       first += static_cast<size_t>(frames_per_pose)) {
    uint32_t f = 0, v = 0;
    for (size_t k = first; k < std::min(drive.lidar_found_boards.size(),
                                        first + static_cast<size_t>(frames_per_pose));
         ++k) {
      f |= drive.lidar_found_boards[k];
      v |= drive.lidar_visible_boards[k];
    }
    found += __builtin_popcount(f);
    visible += __builtin_popcount(v);
  }
  return visible > 0 ? static_cast<double>(found) / visible : 0.0;
}

}  // namespace

// A 1920 x 1200 machine-vision camera with a 6 mm-class lens (~82 deg across), or a fisheye of
// ~190 deg on 1600 x 1200 (Kannala-Brandt, as cv::fisheye calibrates it).
CameraIntrinsics ScenarioCamera(bool fisheye) {
  CameraIntrinsics k;
  if (fisheye) {
    k.width = 1600;
    k.height = 1200;
    k.fx = k.fy = 420.0;
    k.model = DistortionModel::kKannalaBrandt;
    k.k1 = 0.02;
    k.k2 = -0.01;
    k.p1 = k.p2 = 0.0;
    k.k3 = 0.002;
    k.k4 = -0.0005;
  } else {
    k.width = 1920;
    k.height = 1200;
    k.fx = k.fy = 1100.0;
    k.k1 = -0.12;
    k.k2 = 0.05;
    k.p1 = 0.0004;
    k.p2 = -0.0002;
    k.k3 = -0.008;
  }
  k.cx = (k.width - 1) / 2.0 + 7.0;
  k.cy = (k.height - 1) / 2.0 - 5.0;
  return k;
}

std::string RecordingScenarioNames() {
  std::string out;
  for (const Scenario& s : kScenarios) out += (out.empty() ? "" : ", ") + std::string(s.name);
  return out;
}

bool RunRecordingsBench(const RecordingsBenchOptions& o, std::ostream& out, std::ostream* progress,
                        std::string* error) {
  for (const std::string& name : o.scenarios) {
    if (std::none_of(std::begin(kScenarios), std::end(kScenarios),
                     [&](const Scenario& s) { return name == s.name; })) {
      if (error)
        *error = "unknown scenario '" + name + "' (expected " + RecordingScenarioNames() + ")";
      return false;
    }
  }
  nlohmann::json doc;
  doc["seed"] = o.seed;
  doc["seed_kind"] = SeedKind(o.seed);
  doc["extract_planes"] = o.extract_planes;
  bool all_met = true;
  out << "Recorded-style sessions (" << SeedLabel(o.seed) << "). LiDAR detector: planes inside "
      << "refused clusters "
      << (o.extract_planes ? "extracted (calibd-calibrate's default)" : "not extracted") << "\n\n";
  out << "| scenario | camera boards found / in view | LiDAR detector: recall / precision | "
         "LiDAR boards in the solve: recall / precision | verdict "
         "| rotation / translation error | with the true LiDAR boards only | grid search from +-10 "
         "deg | targets met |\n"
         "|---|---|---|---|---|---|---|---|---|\n";
  for (const Scenario& s : kScenarios) {
    if (!o.scenarios.empty() &&
        std::find(o.scenarios.begin(), o.scenarios.end(), s.name) == o.scenarios.end())
      continue;
    const auto t0 = std::chrono::steady_clock::now();
    RecordedDrive drive;
    LidarDetectorConfig lidar;
    lidar.extract_planes = o.extract_planes;
    LidarKind kind;
    LidarKindFromName(s.lidar, &kind, nullptr);
    LidarModel model = MakeLidarModel(kind);
    std::string model_note;
    if (s.generic &&
        !EstimateGenericModel(ScenarioSession(s, o.seed), &model, &model_note, error)) {
      if (error) *error = std::string(s.name) + ": " + *error;
      return false;
    }
    if (!RecordDrive(ScenarioSession(s, o.seed), &drive, error, lidar, &model)) {
      if (error) *error = std::string(s.name) + ": " + *error;
      return false;
    }
    const RangeImage projection = SessionProjection(model);
    const ScoredRun run = RunEngine(drive.config, drive.observations, projection, EngineConfig{},
                                    drive.T_camera_lidar);
    // The same engine on the true LiDAR boards only: what the estimator makes of this session
    // when the detector is perfect (the detector's share of the error is the difference).
    const ScoredRun oracle =
        RunEngine(drive.config,
                  Subset(drive.observations, std::vector<char>(drive.observations.num_frames, 1),
                         std::vector<char>(drive.observations.camera.size(), 1),
                         std::vector<char>(drive.lidar_true.begin(), drive.lidar_true.end())),
                  projection, EngineConfig{}, drive.T_camera_lidar);
    GridTrials grid;
    if (o.grid_trials > 0) {
      // The basin: the engine started from the truth.
      CalibConfig from_truth = drive.config;
      from_truth.prior_T_camera_lidar = drive.T_camera_lidar;
      const ScoredRun basin = RunEngine(from_truth, drive.observations, projection, EngineConfig{},
                                        drive.T_camera_lidar);
      grid = RunGridTrials(drive, projection, o.grid_trials, 20240607,
                           basin.has_estimate ? &basin : nullptr);
    }

    const int tp = drive.lidar_tp, fp = drive.lidar_fp, fn = drive.lidar_fn;
    double recall = tp + fn > 0 ? static_cast<double>(tp) / (tp + fn) : 0.0;
    if (s.frames_per_pose > 1) recall = PoseRecall(drive, s.frames_per_pose);
    const double precision = tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 0.0;
    // The clusters the engine took as the camera's boards (one per correspondence, after its
    // static-scenery step and the grid search): what the extrinsic is solved from.
    int used_tp = 0, used_fp = 0;
    for (int j : run.lidar_clusters_used)
      (drive.lidar_true[static_cast<size_t>(j)] ? used_tp : used_fp) += 1;
    const double used_recall = tp + fn > 0 ? static_cast<double>(used_tp) / (tp + fn) : 0.0;
    const double used_precision =
        used_tp + used_fp > 0 ? static_cast<double>(used_tp) / (used_tp + used_fp) : 0.0;
    const bool updated = run.verdict == "updated";
    const bool accurate = run.has_estimate && run.rotation_error_deg <= s.max_rotation_deg &&
                          run.translation_error_m <= s.max_translation_m;
    const bool met = recall >= s.min_recall && used_precision >= s.min_precision && updated &&
                     accurate && (o.grid_trials == 0 || grid.converged_with == o.grid_trials);
    all_met = all_met && met;
    out << "| " << s.name << " | " << drive.observations.camera.size() << " / "
        << drive.camera_boards_in_view << " | " << FixedDecimal(recall, 3) << " / "
        << FixedDecimal(precision, 3) << " (" << tp << " TP, " << fp << " FP, " << fn << " FN) | "
        << FixedDecimal(used_recall, 3) << " / " << FixedDecimal(used_precision, 3) << " ("
        << used_tp << " TP, " << used_fp << " FP) | " << run.verdict
        << (run.reason.empty() ? "" : " (" + run.reason + ")") << " | "
        << (run.has_estimate ? FixedDecimal(run.rotation_error_deg, 3) + " deg / " +
                                   FixedDecimal(run.translation_error_m * 1000.0, 1) + " mm"
                             : std::string("-"))
        << " (<= " << s.max_rotation_deg << " deg / " << s.max_translation_m * 1000.0 << " mm) | "
        << oracle.verdict << ", "
        << (oracle.has_estimate ? FixedDecimal(oracle.rotation_error_deg, 3) + " deg / " +
                                      FixedDecimal(oracle.translation_error_m * 1000.0, 1) + " mm"
                                : std::string("-"))
        << " | "
        << (o.grid_trials > 0
                ? std::to_string(grid.converged_with) + "/" + std::to_string(o.grid_trials)
                : std::string("-"))
        << " | " << (met ? "yes" : "no") << " |\n"
        << std::flush;
    nlohmann::json j;
    j["name"] = s.name;
    j["what"] = s.what;
    j["lidar_tp"] = tp;
    j["lidar_fp"] = fp;
    j["lidar_fn"] = fn;
    j["lidar_tp_in_solve"] = used_tp;
    j["lidar_fp_in_solve"] = used_fp;
    j["camera_boards"] = drive.observations.camera.size();
    j["camera_boards_in_view"] = drive.camera_boards_in_view;
    j["verdict"] = run.verdict;
    j["reason"] = run.reason;
    j["detail"] = run.detail;
    j["static_scenery_clusters"] = run.static_scenery_clusters;
    if (run.has_estimate) {
      j["rotation_error_deg"] = run.rotation_error_deg;
      j["translation_error_m"] = run.translation_error_m;
      j["reprojection_mean_px"] = run.reprojection_mean_px;
    }
    j["true_boards_only"] = {{"verdict", oracle.verdict}, {"reason", oracle.reason}};
    if (oracle.has_estimate) {
      j["true_boards_only"]["rotation_error_deg"] = oracle.rotation_error_deg;
      j["true_boards_only"]["translation_error_m"] = oracle.translation_error_m;
    }
    j["grid_converged"] = grid.converged_with;
    j["grid_trials"] = o.grid_trials;
    j["targets_met"] = met;
    doc["scenarios"].push_back(j);
    if (progress)
      *progress << "calibd-bench recordings: " << s.name << " (" << s.what
                << "): " << drive.observations.camera.size() << " camera boards of "
                << drive.camera_boards_in_view << " in view, " << std::lround(SecondsSince(t0))
                << " s; " << run.static_scenery_clusters
                << " LiDAR clusters dropped as static scenery; "
                << (model_note.empty() ? "" : model_note + "; ")
                << (run.detail.empty() ? run.verdict : run.detail) << "\n"
                << std::flush;
  }
  out << "\nThe LiDAR detector's recall of a stream scenario counts poses whose board it found in "
         "any of their sweeps.\n";
  out << "\nTargets: a scenario meets them with the LiDAR detector's recall and the precision of "
         "the LiDAR boards in the solve at or above its figures, verdict `updated` within its "
         "error, and every grid search converged. The detector alone sees geometry only, frame by "
         "frame: a flat thing of a board's size is a board to it; the engine then drops clusters "
         "that stand still while the camera's boards move, and takes per camera board the one "
         "cluster inside its predicted region.\n";
  if (!o.json_path.empty() && !WriteFileAtomic(o.json_path, doc.dump(2) + "\n", error))
    return false;
  if (!all_met && error) *error = "some targets are not met (see the table)";
  return all_met;
}

}  // namespace calibd::bench
