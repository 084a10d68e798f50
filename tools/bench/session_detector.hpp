#pragma once
/// \file
/// A simulated session with the real camera and LiDAR detectors built for its boards: the one
/// place where the benches turn simulated frame pairs into detections.

#include <functional>
#include <opencv2/core.hpp>
#include <optional>
#include <string>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "session.hpp"

namespace calibd::bench {

/// The default simulated drive (3 boards, clutter, 6-30 m out and back) squeezed into `frames`
/// frame pairs at the trajectory's rate: fewer frames make a faster drive, not a shorter one.
sim::SessionOptions BenchSessionOptions(const std::string& lidar, unsigned long long seed,
                                        int frames);

/// One frame pair's truth and detections; the caller keeps one and reuses it for every frame.
struct FrameDetections {
  sim::FrameTruth truth;
  LidarDetections lidar;
  CameraDetections camera;  ///< left untouched when the camera was not run
  double lidar_ms = 0.0;    ///< wall time of LidarDetector::Detect
  double camera_ms = 0.0;   ///< wall time of CameraDetector::Detect (0 when not run)
  /// CPU time of the process (every thread: AprilTag's workers too) during each detection; the
  /// simulator's threads have finished by then.
  double lidar_cpu_ms = 0.0, camera_cpu_ms = 0.0;
};

/// One simulated frame pair as the detectors take it: shared between the sessions of one scene
/// (calibd-bench verdicts derives the faults that change only a config from one recording).
struct SimulatedFrame {
  int index = 0;
  /// Empty when the camera was not rendered. Simulate renders into its buffer: one shared with
  /// another frame's image (cv::Mat assignment) would be overwritten.
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
};

/// CPU time of the whole process (CLOCK_PROCESS_CPUTIME_ID), ms.
double ProcessCpuMs();

class DetectedSession {
 public:
  /// Builds the session and both detectors (the camera's default config, `lidar` for the LiDAR,
  /// the workshop's boards); the LiDAR detector with `model` when given (e.g. a generic model
  /// estimated from the sweeps), else the simulated sensor's. False with `error` saying what
  /// failed.
  /// With `edit_user`, the user's config (the simulator's UserConfig()) is changed by it, and both
  /// detectors take the board geometry and the camera's intrinsics from it (a user's config with
  /// wrong figures: the fault campaign).
  /// With `lidar_detector_later`, the LiDAR detector's inputs are checked but the detector (its
  /// references: half a second of the two cores) is built only by BuildLidarDetector(), for a
  /// session that may copy another's detections instead (calibd-bench verdicts).
  bool Init(const sim::SessionOptions& options, std::string* error,
            const LidarDetectorConfig& lidar = LidarDetectorConfig{},
            const LidarModel* model = nullptr,
            const std::function<void(CalibConfig*)>& edit_user = nullptr,
            bool lidar_detector_later = false);
  /// Builds the LiDAR detector Init left for later (nothing when built); false with `error`.
  bool BuildLidarDetector(std::string* error);

  const sim::SessionSimulator& session() const { return session_; }
  /// The config a user would calibrate with: UserConfig(), edited as Init was told.
  const CalibConfig& user_config() const { return user_; }
  const LidarDetectorConfig& lidar_config() const { return lidar_config_; }

  /// Simulates frame pair k and runs the LiDAR detector on its sweep; renders the image and runs
  /// the camera detector only `with_camera` (rendering dominates the time otherwise).
  void Detect(int k, bool with_camera, FrameDetections* out);

  /// Simulates frame pair k into `frame` (the image only `with_camera`, the sweep only
  /// `with_lidar`), detecting nothing.
  void Simulate(int k, bool with_camera, SimulatedFrame* frame, bool with_lidar = true);
  /// Runs the LiDAR detector, and the camera's when the frame has an image, on a pair simulated
  /// by this session or by another of the same scene (the same sim::SessionOptions up to the
  /// LiDAR's noise).
  /// With `same_lidar` or `same_camera`: that detector's output on this frame from a session
  /// whose detector of that sensor was built from the same inputs and has taken the same frames
  /// (its output then equals this one's), copied instead of detected again.
  void DetectFrame(const SimulatedFrame& frame, FrameDetections* out,
                   const LidarDetections* same_lidar = nullptr,
                   const CameraDetections* same_camera = nullptr);
  /// The camera detector takes AprilTag's searches of an image from `memo` where another
  /// detector of the same image left them (CameraDetector::UseSearchMemo); nullptr: none.
  void UseTagSearchMemo(TagSearchMemo* memo);
  /// The detectors of the sensors asked for only, on a pair simulated as for DetectFrame: to keep
  /// a detector whose output other sessions copy in step with the frames (the camera's tracks).
  void DetectOnly(const SimulatedFrame& frame, bool lidar, bool camera, FrameDetections* out);

 private:
  sim::SessionSimulator session_;
  CalibConfig user_;
  LidarDetectorConfig lidar_config_;
  LidarModel lidar_model_;             // what the LiDAR detector is built with
  std::vector<BoardGeometry> boards_;  // what both detectors are built with
  std::optional<LidarDetector> lidar_detector_;
  std::optional<CameraDetector> camera_detector_;
  SimulatedFrame frame_;  // Detect's, reused
};

}  // namespace calibd::bench
