#pragma once
/// \file
/// A simulated calibration session: workshop, trajectory, sensor mounts, the true and the prior
/// extrinsic, and per-frame camera images and LiDAR sweeps with their ground truth.

#include <cstdint>
#include <opencv2/core.hpp>
#include <optional>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/session/config.hpp"
#include "camera_render.hpp"
#include "lidar_sim.hpp"
#include "stills.hpp"
#include "trajectory.hpp"
#include "workshop.hpp"

namespace calibd::sim {

struct SessionOptions {
  uint64_t seed = 1;
  WorkshopOptions workshop;
  TrajectoryOptions trajectory;
  /// Where the boards go in each frame of a trajectory.mode "stills" session.
  StillPoseOptions stills;
  std::string lidar_model = "ot128";
  LidarNoise lidar_noise;
  CameraIntrinsics camera;
  /// What the user's config states of the principal point's precision
  /// (camera.principal_point_sigma_px): a good intrinsic calibration's figure, which holds, since
  /// the simulated camera's intrinsics are exact.
  double stated_principal_point_sigma_px = 1.0;
  CameraImaging imaging;
  std::string image_encoding = "mono8";  ///< "mono8" (raw) or "jpeg" in the log
  int jpeg_quality = 95;
  /// Mounts in the vehicle frame (x forward, y left, z up): x, y, z (m) and roll, pitch, yaw (deg).
  /// The camera's angles rotate a forward-looking body frame; the optical frame (x right, y down,
  /// z forward) follows from it. The true T_camera_lidar = T_vehicle_camera^-1 T_vehicle_lidar.
  Eigen::Matrix<double, 6, 1> lidar_mount =
      (Eigen::Matrix<double, 6, 1>() << 1.2, 0.0, 1.95, 0.0, 0.0, 0.0).finished();
  Eigen::Matrix<double, 6, 1> camera_mount =
      (Eigen::Matrix<double, 6, 1>() << 1.6, 0.05, 1.45, 0.5, 2.0, -0.8).finished();
  /// Prior = truth perturbed by a rotation of prior_rot_deg about prior_rot_axis (random unit axis
  /// when zero) and a translation of prior_trans_m in a random direction: T_prior = T_true * dT.
  double prior_rot_deg = 5.0;
  Eigen::Vector3d prior_rot_axis = Eigen::Vector3d::Zero();
  double prior_trans_m = 0.05;
  /// The camera exposes this long after its trigger (a camera running behind the LiDAR): the
  /// image shows the scene then, and FrameTruth::camera_utime is that true capture time. A fault
  /// to inject; the LiDAR's sweep keeps its phase to the trigger.
  int64_t camera_delay_us = 0;
  /// A rolling shutter: the image's rows are read out top to bottom over this long, the first at
  /// the capture time (FrameTruth::camera_utime); while the vehicle moves, each row sees the scene
  /// from where the camera is at its own time. A fault to inject; 0: a global shutter.
  int64_t camera_readout_us = 0;
  int64_t start_utime = 1767225600000000;  ///< 2026-01-01T00:00:00Z, microseconds
  std::string camera_id = "front";
  std::string lidar_id = "roof";
  std::string camera_serial = "CAM-SIM-0001";
  std::string lidar_serial = "LDR-SIM-0001";

  bool IsValid(std::string* error) const;
};

/// Ground truth of one board in one frame.
struct BoardTruth {
  int board_id = 0;
  Pose T_camera_board;  ///< at the camera's capture time
  Pose T_lidar_board;   ///< at the LiDAR frame start (points fire later: see time offsets)
  bool tag_in_image =
      false;  ///< all four tag corners project into the image, tag facing the camera
  std::vector<int> lidar_point_indices;  ///< points of this frame that hit the board
};

struct FrameTruth {
  int index = 0;
  int64_t camera_utime = 0;  ///< mid-exposure
  int64_t lidar_utime = 0;   ///< sweep start
  Pose T_world_vehicle;      ///< at the camera time
  std::vector<BoardTruth> boards;
};

class SessionSimulator {
 public:
  /// Builds the scene and sensors; false with `error` naming the bad option.
  bool Init(const SessionOptions& options, std::string* error);

  int num_frames() const {
    return options_.trajectory.num_frames() *
           (options_.trajectory.mode == "stills" ? options_.stills.frames_per_pose : 1);
  }
  const SessionOptions& options() const { return options_; }
  /// The scene: the workshop of a drive; in a still-pose session, the pose of the last simulated
  /// frame (pose 0 before any).
  const Workshop& workshop() const { return WorkshopOf(last_frame_); }
  const LidarModel& lidar_model() const { return lidar_->model(); }
  const CameraModel& camera_model() const { return camera_->model(); }
  Pose T_camera_lidar() const { return T_camera_lidar_; }
  Pose prior_T_camera_lidar() const { return prior_T_camera_lidar_; }
  Pose T_vehicle_lidar() const { return T_vehicle_lidar_; }
  Pose T_vehicle_camera() const { return T_vehicle_camera_; }
  /// Offset from the LiDAR frame start to the moment the sweep crosses the camera's view: the
  /// camera is triggered then (phase lock, as on real vehicles), in microseconds.
  int64_t camera_phase_us() const { return camera_phase_us_; }

  /// Simulates frame k: the image (if non-null), the sweep (if non-null; else the truth's boards
  /// list no LiDAR points) and the truth. Deterministic per (seed, k).
  void SimulateFrame(int k, cv::Mat* image, LidarScan* scan, FrameTruth* truth);

  /// The calibration config a user would write for this vehicle: intrinsics, boards, LiDAR model
  /// and the perturbed prior. Nothing from the truth beyond what a real vehicle would know.
  CalibConfig UserConfig() const;

 private:
  SessionOptions options_;
  Workshop workshop_;
  std::optional<LidarSimulator> lidar_;
  std::optional<CameraRenderer> camera_;  // built once: its ray table is large
  Pose T_vehicle_lidar_, T_vehicle_camera_, T_camera_lidar_, prior_T_camera_lidar_;
  int64_t camera_phase_us_ = 0;
  std::vector<Workshop> still_poses_;  // one scene per pose of a still-pose session, else empty
  int last_frame_ = 0;                 // its pose
  int last_rendered_ = -2;             // the frame the camera rendered last (RenderRepeat)

  const Workshop& WorkshopOf(int k) const {
    return still_poses_.empty() ? workshop_ : still_poses_[static_cast<size_t>(k)];
  }
  bool BuildStillPoses(std::string* error);
};

}  // namespace calibd::sim
