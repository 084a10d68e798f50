#include "calib_experiments.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <atomic>
#include <cassert>
#include <chrono>
#include <cmath>
#include <limits>
#include <mutex>
#include <random>
#include <thread>

#include "calibd/core/common/stats.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/solve/grid_search.hpp"
#include "session_detector.hpp"

namespace calibd::bench {

namespace {

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? 0.0 : sum / static_cast<double>(v.size());
}

// Adds one frame's LiDAR true/false positives and misses to the drive's counts.
void ScoreLidar(const FrameDetections& frame, std::vector<int>* board_of_point,
                RecordedDrive* drive) {
  board_of_point->clear();
  const auto& truth = frame.truth.boards;
  for (size_t b = 0; b < truth.size(); ++b) {
    drive->camera_boards_in_view += truth[b].tag_in_image ? 1 : 0;
    for (int i : truth[b].lidar_point_indices) {
      if (static_cast<size_t>(i) >= board_of_point->size())
        board_of_point->resize(static_cast<size_t>(i) + 1, -1);
      (*board_of_point)[static_cast<size_t>(i)] = static_cast<int>(b);
    }
  }
  std::vector<char> found(truth.size(), 0);
  for (const BoardCluster& c : frame.lidar.boards) {
    std::vector<int> votes(truth.size(), 0);
    for (int k = c.first_point; k < c.first_point + c.num_points; ++k) {
      const auto i = static_cast<size_t>(frame.lidar.point_indices[static_cast<size_t>(k)]);
      if (i < board_of_point->size() && (*board_of_point)[i] >= 0)
        ++votes[static_cast<size_t>((*board_of_point)[i])];
    }
    const auto best = std::max_element(votes.begin(), votes.end());
    if (best != votes.end() && 2 * *best > c.num_points) {
      found[static_cast<size_t>(best - votes.begin())] = 1;
      ++drive->lidar_tp;
      drive->lidar_true.push_back(1);
    } else {
      ++drive->lidar_fp;
      drive->lidar_true.push_back(0);
    }
  }
  uint32_t found_bits = 0, visible_bits = 0;
  for (size_t b = 0; b < truth.size(); ++b) {
    const bool visible =
        static_cast<int>(truth[b].lidar_point_indices.size()) >= kVisibleBoardPoints;
    if (!found[b] && visible) ++drive->lidar_fn;
    if (b < 32 && found[b]) found_bits |= 1u << b;
    if (b < 32 && (found[b] || visible)) visible_bits |= 1u << b;
  }
  drive->lidar_found_boards.push_back(found_bits);
  drive->lidar_visible_boards.push_back(visible_bits);
}

}  // namespace

void ParallelTasks(int count, int threads, const std::function<void(int)>& task,
                   std::ostream* progress, const std::string& label, const char* unit, int every) {
  std::atomic<int> next{0}, done{0};
  std::mutex progress_mutex;
  const auto t0 = std::chrono::steady_clock::now();
  auto work = [&] {
    for (int k = next++; k < count; k = next++) {
      task(k);
      const int n = ++done;
      if (progress && (n % every == 0 || n == count)) {
        std::lock_guard<std::mutex> lock(progress_mutex);
        *progress << label << ": " << n << "/" << count << " " << unit << ", "
                  << std::lround(SecondsSince(t0)) << " s\n"
                  << std::flush;
      }
    }
  };
  std::vector<std::thread> workers;
  for (int t = 1; t < std::max(1, threads); ++t) workers.emplace_back(work);
  work();
  for (auto& w : workers) w.join();
}

bool DriveRecorder::Init(const sim::SessionOptions& options, RecordedDrive* drive,
                         std::string* error, const LidarDetectorConfig& lidar,
                         const LidarModel* model, const RecordingFaults& faults,
                         KeepRecording keep_going, bool lidar_detector_later) {
  if (!detected_.Init(options, error, lidar, model, faults.edit_config, lidar_detector_later))
    return false;
  drive_ = drive;
  faults_ = faults;
  keep_going_ = std::move(keep_going);
  drive->seed = options.seed;
  drive->config = detected_.user_config();
  drive->T_camera_lidar = detected_.session().T_camera_lidar();
  // As tests/recorded_session.hpp: room for every frame pair, so positions stay aligned.
  drive->observations.Reserve(num_frames(), static_cast<int>(drive->config.boards.size()) + 4,
                              4096);
  drive->vehicle_positions.clear();
  drive->timings.clear();
  drive->incomplete_frames = 0;
  drive->lidar_tp = drive->lidar_fp = drive->lidar_fn = drive->camera_boards_in_view = 0;
  drive->lidar_true.clear();
  drive->lidar_found_boards.clear();
  drive->lidar_visible_boards.clear();
  first_camera_utime_ = 0;
  detect_s_ = 0.0;
  return true;
}

bool DriveRecorder::Add(const SimulatedFrame& simulated, const DriveRecorder* same_lidar,
                        const DriveRecorder* same_camera) {
  const auto t0 = std::chrono::steady_clock::now();
  RecordedDrive* drive = drive_;
  detected_.DetectFrame(simulated, &frame_, same_lidar ? &same_lidar->frame_.lidar : nullptr,
                        same_camera ? &same_camera->frame_.camera : nullptr);
  ScoreLidar(frame_, &board_of_point_, drive);
  if (simulated.index == 0) first_camera_utime_ = frame_.truth.camera_utime;
  const auto drift_us =
      std::llround(static_cast<double>(frame_.truth.camera_utime - first_camera_utime_) *
                   faults_.camera_clock_drift_ppm * 1e-6);
  FrameTimes times{frame_.truth.camera_utime + faults_.camera_stamp_shift_us + drift_us,
                   frame_.truth.lidar_utime};
  if (faults_.one_time_per_pair) times.camera_utime = times.lidar_utime;
  if (faults_.no_times) times = FrameTimes{};
  if (!drive->observations.AddFrame(frame_.camera, frame_.lidar, drive->config.boards, times))
    ++drive->incomplete_frames;
  drive->vehicle_positions.push_back(frame_.truth.T_world_vehicle.translation());
  drive->timings.push_back({frame_.lidar_ms, frame_.camera_ms, frame_.lidar_cpu_ms,
                            frame_.camera_cpu_ms, frame_.camera.full_frame_search});
  detect_s_ += SecondsSince(t0);
  return !keep_going_ || keep_going_(drive->observations, frame_.truth);
}

void DriveRecorder::DetectOnly(const SimulatedFrame& frame, bool lidar, bool camera) {
  const auto t0 = std::chrono::steady_clock::now();
  detected_.DetectOnly(frame, lidar, camera, &frame_);
  detect_s_ += SecondsSince(t0);
}

void DriveRecorder::Finish(double simulation_seconds) {
  drive_->detect_s = detect_s_ + simulation_seconds;
}

bool RecordDrive(const sim::SessionOptions& options, RecordedDrive* drive, std::string* error,
                 const LidarDetectorConfig& lidar, const LidarModel* model,
                 const RecordingFaults& faults, const KeepRecording& keep_going) {
  DriveRecorder recorder;
  if (!recorder.Init(options, drive, error, lidar, model, faults, keep_going)) return false;
  SimulatedFrame frame;
  double simulation_s = 0.0;
  for (int k = 0; k < recorder.num_frames(); ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    recorder.session().Simulate(k, true, &frame);
    simulation_s += SecondsSince(t0);
    if (!recorder.Add(frame)) break;
  }
  recorder.Finish(simulation_s);
  return true;
}

SessionObservations DistanceBand(const SessionObservations& s, double min_m, double max_m,
                                 double baseline_m) {
  std::vector<char> keep_frame(static_cast<size_t>(s.num_frames), 0);
  std::vector<char> keep_camera(s.camera.size(), 0), keep_lidar(s.lidar.size(), 0);
  for (size_t i = 0; i < s.camera.size(); ++i) {
    const double d = s.camera[i].T_camera_board.translation().norm();
    if (d > min_m && d < max_m) {
      keep_camera[i] = 1;
      keep_frame[static_cast<size_t>(s.camera[i].frame)] = 1;
    }
  }
  for (size_t j = 0; j < s.lidar.size(); ++j) {
    const auto& c = s.lidar[j];
    if (!keep_frame[static_cast<size_t>(c.frame)] || c.num_points <= 0) continue;
    Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
    for (int p = 0; p < c.num_points; ++p)
      centroid += s.points[static_cast<size_t>(c.first_point + p)].cast<double>();
    const double r = (centroid / static_cast<double>(c.num_points)).norm();
    keep_lidar[j] = r > min_m - baseline_m && r < max_m + baseline_m ? 1 : 0;
  }
  return Subset(s, keep_frame, keep_camera, keep_lidar);
}

SessionObservations SampleByTravel(const SessionObservations& s,
                                   const std::vector<Eigen::Vector3d>& vehicle_positions,
                                   double min_step_m) {
  std::vector<char> keep_frame(static_cast<size_t>(s.num_frames), 0);
  const std::vector<char> keep_camera(s.camera.size(), 1), keep_lidar(s.lidar.size(), 1);
  Eigen::Vector3d last = Eigen::Vector3d::Zero();
  for (size_t f = 0; f < keep_frame.size() && f < vehicle_positions.size(); ++f) {
    if (f > 0 && (vehicle_positions[f] - last).norm() < min_step_m) continue;
    keep_frame[f] = 1;
    last = vehicle_positions[f];
  }
  return Subset(s, keep_frame, keep_camera, keep_lidar);
}

const char* MethodName(Method method) {
  switch (method) {
    case Method::kIndirect:
      return "indirect";
    case Method::kDirect:
      return "direct";
    case Method::kDirectRefined:
      return "direct+refinement";
  }
  return "direct+refinement";
}

EngineConfig BenchEngine(Method method) {
  EngineConfig engine;
  engine.stability_runs = 0;
  engine.method =
      method == Method::kIndirect ? EngineConfig::Method::kIndirect : EngineConfig::Method::kDirect;
  engine.direct.refine_board_poses = method == Method::kDirectRefined;
  return engine;
}

ScoredRun RunEngine(const CalibConfig& config, const SessionObservations& s,
                    const RangeImage& projection, const EngineConfig& engine,
                    const Pose& T_camera_lidar_true) {
  ObservationSet correspondences;
  const CalibrationOutcome outcome = Calibrate(config, s, projection, engine, &correspondences);
  ScoredRun r;
  for (const BoardObservation& o : correspondences.observations)
    if (o.lidar_cluster >= 0) r.lidar_clusters_used.push_back(o.lidar_cluster);
  r.verdict = VerdictName(outcome.verdict);
  r.reason = NameOf(outcome.reason);
  r.detail = outcome.detail;
  r.static_scenery_clusters = outcome.static_scenery_clusters;
  r.has_estimate = outcome.solved;
  r.grid_ms = outcome.grid.search_ms;
  r.optimise_ms = outcome.optimise_ms;
  r.frames = s.num_frames;
  r.camera_boards = static_cast<int>(s.camera.size());
  r.boards_used = outcome.quality.boards_used;
  r.quality = outcome.quality;
  r.board_translation_change_m = outcome.board_translation_change_m;
  if (!r.has_estimate) return r;
  const Pose& T_est = outcome.T_camera_lidar;
  const Eigen::AngleAxisd delta(T_camera_lidar_true.linear().transpose() * T_est.linear());
  r.error_rpy_deg = delta.angle() * delta.axis() * kRad2Deg;
  r.rotation_error_deg = RotationAngle(T_est.linear(), T_camera_lidar_true.linear()) * kRad2Deg;
  r.translation_error_xyz_m = T_est.translation() - T_camera_lidar_true.translation();
  r.translation_error_m = r.translation_error_xyz_m.norm();
  r.reprojection_mean_px = outcome.quality.reprojection_mean_px;
  return r;
}

Summary Summarise(const std::vector<ScoredRun>& runs) {
  Summary s;
  s.runs = static_cast<int>(runs.size());
  std::vector<double> rot, trans, reproj, grid, opt, frames, boards;
  std::vector<Eigen::Vector3d> rpy;
  for (const auto& r : runs) {
    frames.push_back(r.frames);
    boards.push_back(r.camera_boards);
    if (!r.has_estimate) {
      if (s.missing_reason.empty()) s.missing_reason = r.reason.empty() ? "no_estimate" : r.reason;
      continue;
    }
    ++s.estimates;
    if (!r.reason.empty()) {
      ++s.gated;
      if (s.gate_reason.empty()) s.gate_reason = r.reason;
    }
    rot.push_back(r.rotation_error_deg);
    trans.push_back(r.translation_error_m);
    reproj.push_back(r.reprojection_mean_px);
    grid.push_back(r.grid_ms);
    opt.push_back(r.optimise_ms);
    rpy.push_back(r.error_rpy_deg);
  }
  s.frames_mean = Mean(frames);
  s.camera_boards_mean = Mean(boards);
  if (rot.empty()) return s;
  s.rotation_mean_deg = Mean(rot);
  s.rotation_max_deg = *std::max_element(rot.begin(), rot.end());
  s.translation_mean_m = Mean(trans);
  s.translation_max_m = *std::max_element(trans.begin(), trans.end());
  s.reprojection_mean_px = Mean(reproj);
  s.grid_median_ms = Median(grid);
  s.optimise_median_ms = Median(opt);
  if (rpy.size() < 2) {
    s.std_rpy_deg.setConstant(std::numeric_limits<double>::quiet_NaN());
    return s;
  }
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  for (const auto& v : rpy) mean += v;
  mean /= static_cast<double>(rpy.size());
  Eigen::Vector3d sq = Eigen::Vector3d::Zero();
  for (const auto& v : rpy) sq += (v - mean).cwiseAbs2();
  s.std_rpy_deg = (sq / static_cast<double>(rpy.size() - 1)).cwiseSqrt();
  return s;
}

GridTrials RunGridTrials(const RecordedDrive& drive, const RangeImage& projection, int trials,
                         uint64_t rng_seed, const ScoredRun* basin) {
  GridTrials g;
  if (basin) g.converged_deg = 0.05;
  std::mt19937_64 rng(rng_seed);
  std::uniform_real_distribution<double> angle(-g.max_deg, g.max_deg);
  const EngineConfig with_search = BenchEngine(Method::kDirectRefined);
  EngineConfig without_search = with_search;
  without_search.grid.range_deg = 0.0;
  without_search.grid.refine = false;
  // The paper optimises straight from the prior: associate with whatever points the prior puts
  // in the regions instead of refusing a weak prior (no_grid_candidate then means none at all).
  without_search.grid.min_points = 1;
  without_search.grid.min_point_fraction = 0.0;
  CalibConfig config = drive.config;
  for (int t = 0; t < trials; ++t) {
    Eigen::Vector3d rpy_deg;
    for (int a = 0; a < 3; ++a) rpy_deg(a) = angle(rng);
    g.perturbations_deg.push_back(rpy_deg);
    // Paper §IV-D: rotation only, added to the accurate extrinsic.
    config.prior_T_camera_lidar = PerturbExtrinsic(drive.T_camera_lidar, rpy_deg / kRad2Deg);
    g.with_search.push_back(
        RunEngine(config, drive.observations, projection, with_search, drive.T_camera_lidar));
    g.without_search.push_back(
        RunEngine(config, drive.observations, projection, without_search, drive.T_camera_lidar));
    auto converged = [&](const ScoredRun& r) {
      if (!r.has_estimate) return 0;
      // Small angles: the difference of the two error vectors is the angle between estimates.
      const double off =
          basin ? (r.error_rpy_deg - basin->error_rpy_deg).norm() : r.rotation_error_deg;
      return off < g.converged_deg ? 1 : 0;
    };
    g.converged_with += converged(g.with_search.back());
    g.converged_without += converged(g.without_search.back());
  }
  return g;
}

}  // namespace calibd::bench
