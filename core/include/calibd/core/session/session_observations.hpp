#pragma once
/// \file
/// The compact record of a calibration session that the engine works on: per frame pair, the
/// camera's board detections and the LiDAR's board clusters (points kept in one pool). Capacity is
/// reserved once from the config; adding beyond it is refused, never grown.

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <vector>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"

namespace calibd {

/// When a frame pair was captured (microseconds, any common clock). Zeros when unknown: then
/// no motion compensation is possible and the pair counts as captured at one instant.
struct FrameTimes {
  int64_t camera_utime = 0;  ///< the image's capture time (mid-exposure)
  int64_t lidar_utime = 0;   ///< the sweep's start; points fire later (their time offsets)
};

struct SessionObservations {
  struct CameraBoard {
    int frame = 0;
    int board_index = -1;  ///< index into the configured boards
    Pose T_camera_board = Pose::Identity();
    std::array<Eigen::Vector2d, 4> corners_px;  ///< AprilTag order, OpenCV pixel convention
    BoardOutline outline;                       ///< BoardDetection2D::outline
  };
  struct LidarCluster {
    int frame = 0;
    int first_point = 0;  ///< into points
    int num_points = 0;
  };

  std::vector<CameraBoard> camera;      ///< in frame order
  std::vector<LidarCluster> lidar;      ///< in frame order
  std::vector<Eigen::Vector3f> points;  ///< LiDAR frame, m
  /// Per point: its firing time minus its frame's camera time, s (the LiDAR and camera clocks
  /// are assumed synchronised, e.g. by PTP). 0 when the times are unknown.
  std::vector<float> point_dt;
  std::vector<FrameTimes> frame_times;  ///< one per frame pair
  int num_frames = 0;
  /// Over the LiDAR clouds AddFrame recorded: points with a finite range in the model's range
  /// limits, and how many of them fell outside the configured model's field of view (a cloud from
  /// another LiDAR model, or in other axes, than the configuration names).
  int64_t lidar_valid_points = 0;
  int64_t lidar_outside_points = 0;

  /// Reserves room for `max_frames` frame pairs of up to `max_boards` boards and clusters each,
  /// with up to `max_points_per_cluster` points each.
  void Reserve(int max_frames, int max_boards, int max_points_per_cluster);
  void Clear();

  /// Starts a new frame pair; false when the frame capacity is used up.
  bool BeginFrame(const FrameTimes& times = {});
  /// Adds to the current frame; false (nothing added) when a capacity would be exceeded.
  /// `time_s` (may be null: all 0) holds each point's firing time after the sweep start.
  bool AddCameraBoard(const CameraBoard& board);
  bool AddLidarCluster(const Eigen::Vector3f* cluster_points, const float* time_s, int count);

  /// Records one frame pair from the detectors' outputs (camera boards mapped from board_id to
  /// their index in `boards`). False when a capacity ran out: what fitted is kept, the rest
  /// dropped.
  bool AddFrame(const CameraDetections& camera_detections, const LidarDetections& lidar_detections,
                const std::vector<BoardGeometry>& boards, const FrameTimes& times = {});

 private:
  int max_frames_ = 0;
};

/// A copy of `s` holding its frame pairs `frames` in that order (a frame may repeat), renumbered
/// 0, 1, ..., and in them only the camera boards with keep_camera[i] and the LiDAR clusters with
/// keep_lidar[j] (indices into s.camera and s.lidar). Built through the store's public API,
/// capacities sized to fit. `source_lidar` (optional) receives each kept cluster's index in
/// s.lidar.
SessionObservations SelectFrames(const SessionObservations& s, const std::vector<int>& frames,
                                 const std::vector<char>& keep_camera,
                                 const std::vector<char>& keep_lidar,
                                 std::vector<int>* source_lidar = nullptr);

/// A copy of `s` holding the frame pairs with keep_frame[f] (renumbered in order) and in them only
/// the camera boards with keep_camera[i] and the LiDAR clusters with keep_lidar[j] (indices into
/// s.camera and s.lidar). Built through the store's public API, capacities sized to fit.
SessionObservations Subset(const SessionObservations& s, const std::vector<char>& keep_frame,
                           const std::vector<char>& keep_camera,
                           const std::vector<char>& keep_lidar);

}  // namespace calibd
