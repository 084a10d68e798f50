#pragma once
/// \file
/// The pieces of `calibd-bench calib`: a drive detected once, subsets of its observations (by
/// camera-to-board distance, by distance travelled), one engine run scored against the truth,
/// figures over several drives, and the grid search's convergence trials.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <functional>
#include <ostream>
#include <string>
#include <vector>

#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "session.hpp"
#include "session_detector.hpp"

namespace calibd::bench {

/// One simulated drive, detected once: every experiment runs on its stored observations.
struct RecordedDrive {
  unsigned long long seed = 0;
  CalibConfig config;                      ///< what a user would write (the simulator's prior)
  Pose T_camera_lidar = Pose::Identity();  ///< the truth
  SessionObservations observations;
  std::vector<Eigen::Vector3d> vehicle_positions;  ///< per frame pair, world frame, m (truth)
  int incomplete_frames = 0;  ///< frame pairs whose detections did not all fit the store
  double detect_s = 0.0;      ///< wall time of simulation and detection
  /// Per frame pair: wall and process CPU time of each detector (FrameDetections).
  struct FrameTiming {
    double lidar_ms = 0.0, camera_ms = 0.0, lidar_cpu_ms = 0.0, camera_cpu_ms = 0.0;
    bool camera_full_frame = false;  ///< the camera detector searched the whole image
  };
  std::vector<FrameTiming> timings;
  /// LiDAR detections against the truth: a cluster is a true positive when most of its points lie
  /// on one true board; a board with at least kVisibleBoardPoints points and no true positive is
  /// a false negative.
  int lidar_tp = 0, lidar_fp = 0, lidar_fn = 0;
  /// Per LiDAR detection, in the order they entered `observations`: 1 for a true positive.
  std::vector<char> lidar_true;
  /// Per frame pair, bit b for board b: found by a true positive; visible (found or missed).
  std::vector<uint32_t> lidar_found_boards, lidar_visible_boards;
  int camera_boards_in_view = 0;  ///< boards whose tag the camera could see (truth)
};

/// A board with fewer LiDAR points is not counted as missed (too far or hidden to be a plane).
inline constexpr int kVisibleBoardPoints = 30;

/// Where a recording differs from the simulated truth (the fault campaign, calibd-bench verdicts).
struct RecordingFaults {
  /// Changes the simulator's UserConfig() into the user's (wrong sizes, intrinsics or prior):
  /// the detectors and the engine use it. Empty: UserConfig() as it is.
  std::function<void(CalibConfig*)> edit_config;
  int64_t camera_stamp_shift_us = 0;  ///< added to every camera stamp (a wrong clock)
  /// The camera's clock runs this much fast against the LiDAR's, parts per million: its stamps
  /// drift from the truth by that share of the time since the first frame.
  double camera_clock_drift_ppm = 0.0;
  bool no_times = false;  ///< frame pairs without capture times (paired by file name)
  /// Each pair stamped with one time, its LiDAR sweep's start, for both sensors: a folder whose
  /// frames.csv a user wrote for pairs matched by file name, at the sensors' nominal rate.
  bool one_time_per_pair = false;
};

/// Runs task(k) for k in [0, count) on `threads` threads (the caller's among them), and after
/// each task, when `progress` is given and `every` divides the number done (or all are done),
/// prints "`label`: done/count `unit`, seconds" on it.
void ParallelTasks(int count, int threads, const std::function<void(int)>& task,
                   std::ostream* progress, const std::string& label, const char* unit,
                   int every = 1);

using KeepRecording =
    std::function<bool(const SessionObservations& observations, const sim::FrameTruth& truth)>;

/// Detects a drive frame pair by frame pair into a RecordedDrive, the way tests/
/// recorded_session.hpp does: the pairs come from its own session (RecordDrive), or from another
/// session of the same scene, so that several configs and recording faults share one simulation
/// (calibd-bench verdicts).
class DriveRecorder {
 public:
  /// Builds the session and its detectors (DetectedSession::Init with `faults.edit_config`); the
  /// LiDAR detector with `model` when given. With `keep_going`, asked after each pair with the
  /// observations so far and the pair's truth, recording stops at the first false (e.g. where the
  /// agent's session machine would end its collection). `lidar_detector_later`: as
  /// DetectedSession::Init's.
  bool Init(const sim::SessionOptions& options, RecordedDrive* drive, std::string* error,
            const LidarDetectorConfig& lidar = LidarDetectorConfig{},
            const LidarModel* model = nullptr, const RecordingFaults& faults = {},
            KeepRecording keep_going = nullptr, bool lidar_detector_later = false);
  /// This recording's own session: it simulates the pairs Add takes.
  DetectedSession& session() { return detected_; }
  int num_frames() const { return detected_.session().num_frames(); }
  /// Detects pair `frame` (simulated by session() or by a session of the same scene) and records
  /// it with the recording's faults; false once keep_going said stop.
  /// With `same_lidar` / `same_camera`: a recorder of the same scene whose detector of that
  /// sensor matches this one's and has just detected this frame (DetectedSession::DetectFrame).
  bool Add(const SimulatedFrame& frame, const DriveRecorder* same_lidar = nullptr,
           const DriveRecorder* same_camera = nullptr);
  /// Detects with the sensors' detectors asked for, records nothing: a recording that has ended
  /// keeps a detector others copy (Add's same_lidar, same_camera) in step with the frames.
  void DetectOnly(const SimulatedFrame& frame, bool lidar, bool camera);
  /// Ends the recording: the drive's detection time, `seconds` spent in the simulations it took
  /// its pairs from (its share of a shared one) added.
  void Finish(double simulation_seconds);

 private:
  DetectedSession detected_;
  RecordedDrive* drive_ = nullptr;
  RecordingFaults faults_;
  KeepRecording keep_going_;
  FrameDetections frame_;
  std::vector<int> board_of_point_;
  int64_t first_camera_utime_ = 0;
  double detect_s_ = 0.0;  // wall time of Add's detections
};

/// Simulates every frame pair of a drive and detects it (DriveRecorder) into `drive`.
bool RecordDrive(const sim::SessionOptions& options, RecordedDrive* drive, std::string* error,
                 const LidarDetectorConfig& lidar = LidarDetectorConfig{},
                 const LidarModel* model = nullptr, const RecordingFaults& faults = {},
                 const KeepRecording& keep_going = nullptr);

/// Board observations at camera-to-board distances in (min_m, max_m) only (paper Table II: close
/// < 8.5 m, far > 25 m). Camera boards are kept by their PnP distance. A LiDAR cluster's board is
/// unknown before the grid search, so clusters are kept by their centroid's range from the LiDAR
/// within the band widened by `baseline_m` (the camera-LiDAR offset), in frame pairs that keep a
/// camera board: left in, the other clusters would dilute the grid search's point fraction.
SessionObservations DistanceBand(const SessionObservations& s, double min_m, double max_m,
                                 double baseline_m);

/// Frame pairs kept only when the vehicle is at least `min_step_m` (straight line) from where the
/// last kept pair was taken (paper Fig. 7); the first pair is always kept.
SessionObservations SampleByTravel(const SessionObservations& s,
                                   const std::vector<Eigen::Vector3d>& vehicle_positions,
                                   double min_step_m);

/// The optimisers compared in Table II and Fig. 7.
enum class Method {
  kIndirect,       ///< Huang & Grizzle's vertex fit + PnP (the paper's baseline)
  kDirect,         ///< paper Eq. 4: camera board poses held exact
  kDirectRefined,  ///< ours, the default: board poses refined with the LiDAR planes
};
const char* MethodName(Method method);
/// The engine's defaults for `method`, without the half-data stability re-solves (bench time).
EngineConfig BenchEngine(Method method);

/// One engine run scored against the truth.
struct ScoredRun {
  std::string verdict;              ///< VerdictName()
  std::string reason;               ///< reason code when rejected
  std::string detail;               ///< the outcome's explanation
  int static_scenery_clusters = 0;  ///< LiDAR clusters the engine dropped as static scenery
  /// The optimiser produced the estimate: accepted, or rejected by a quality gate that is checked
  /// only after the solve (the outcome then still carries the solution). False when the engine
  /// stopped before it (no correspondences, too few boards, solver failure...).
  bool has_estimate = false;
  double rotation_error_deg = 0.0;  ///< angle of R_est^T R_true
  double translation_error_m = 0.0;
  /// t_est - t_true on the camera's axes (x right, y down, z forward), m.
  Eigen::Vector3d translation_error_xyz_m = Eigen::Vector3d::Zero();
  /// log(R_true^T R_est) on the LiDAR's axes, deg: x forward (roll), y (pitch), z (yaw).
  Eigen::Vector3d error_rpy_deg = Eigen::Vector3d::Zero();
  double reprojection_mean_px = 0.0;        ///< paper Table I metric
  QualityFigures quality;                   ///< the outcome's (calibd-bench verdicts prints them)
  double board_translation_change_m = 0.0;  ///< board-pose refinement's mean change
  double grid_ms = 0.0, optimise_ms = 0.0;
  int frames = 0;         ///< frame pairs in the (sub)session
  int camera_boards = 0;  ///< camera board detections in the (sub)session
  int boards_used = 0;    ///< correspondences after the grid search
  /// The LiDAR cluster of each correspondence: indices into the session's `lidar`.
  std::vector<int> lidar_clusters_used;
};

ScoredRun RunEngine(const CalibConfig& config, const SessionObservations& s,
                    const RangeImage& projection, const EngineConfig& engine,
                    const Pose& T_camera_lidar_true);

/// Figures over drives, from the runs with an estimate. Tables print a figure only when every run
/// has one (complete()), and otherwise `missing_reason`.
struct Summary {
  int runs = 0, estimates = 0;
  std::string missing_reason;  ///< reason code of the first run without an estimate
  int gated = 0;               ///< estimates whose outcome a post-solve quality gate rejected
  std::string gate_reason;     ///< reason code of the first of them
  double rotation_mean_deg = 0.0, rotation_max_deg = 0.0;
  double translation_mean_m = 0.0, translation_max_m = 0.0;
  /// Sample standard deviation (n - 1) of error_rpy_deg; NaN below two estimates.
  Eigen::Vector3d std_rpy_deg = Eigen::Vector3d::Zero();
  double reprojection_mean_px = 0.0;
  double grid_median_ms = 0.0, optimise_median_ms = 0.0;
  double frames_mean = 0.0, camera_boards_mean = 0.0;  ///< over every run

  bool complete() const { return runs > 0 && estimates == runs; }
};

Summary Summarise(const std::vector<ScoredRun>& runs);

/// Paper §IV-D: `trials` priors, each the truth rotated by roll/pitch/yaw drawn uniformly in
/// +-max_deg about the LiDAR axes (PerturbExtrinsic) from a fixed seed, calibrated with the default
/// grid search and without it (range 0, no refinement, no minimum point count: only the prior is
/// scored, and it associates whatever it aligns, as the paper optimises from the prior directly).
struct GridTrials {
  double max_deg = 10.0;
  /// A trial converged when its estimate is this close to the truth (paper §IV-D), or with a
  /// basin run, to that run's estimate.
  double converged_deg = 0.2;
  std::vector<Eigen::Vector3d> perturbations_deg;
  std::vector<ScoredRun> with_search, without_search;  ///< one per trial, same priors
  int converged_with = 0, converged_without = 0;
};

/// Trials from priors rotated by up to max_deg. With `basin` (the engine started from the truth),
/// a trial converged when it ends within 0.05 deg of that run's estimate: the search found the
/// optimiser's basin, whatever the estimator's own error on the session.
GridTrials RunGridTrials(const RecordedDrive& drive, const RangeImage& projection, int trials,
                         uint64_t rng_seed, const ScoredRun* basin = nullptr);

/// Table II and Fig. 7 columns, in this order.
inline constexpr std::array<Method, 3> kMethods{Method::kIndirect, Method::kDirect,
                                                Method::kDirectRefined};
using RunsByMethod = std::array<std::vector<ScoredRun>, kMethods.size()>;

/// Everything `calibd-bench calib` measures for one LiDAR model; runs are one per drive.
struct LidarResults {
  struct Drive {
    unsigned long long seed = 0;
    int frames = 0, camera_boards = 0, lidar_clusters = 0, incomplete_frames = 0;
    double detect_s = 0.0;
  };
  struct AlphaRow {  ///< Table I
    double alpha_m = 0.0;
    std::vector<ScoredRun> indirect, direct;
  };
  struct BandRow {  ///< Table II
    std::string name;
    double min_m = 0.0, max_m = 0.0;  ///< camera-to-board distance band
    RunsByMethod runs;
  };
  struct SamplingRow {  ///< Fig. 7
    double min_step_m = 0.0;
    RunsByMethod runs;
  };
  std::string lidar;
  std::vector<Drive> drives;
  std::vector<ScoredRun> accuracy;  ///< the default engine
  std::vector<AlphaRow> alphas;
  std::vector<BandRow> bands;
  std::vector<SamplingRow> sampling;
  GridTrials grid;  ///< on the first drive
};

}  // namespace calibd::bench
