#pragma once
/// \file
/// Simulates one LiDAR sweep over a Scene: the sensor's scan pattern, motion during the sweep,
/// range noise and quantization, angular jitter, dropouts, mixed points at depth edges.

#include <cstdint>
#include <vector>

#include "calibd/core/lidar_model.hpp"
#include "scene.hpp"

namespace calibd::sim {

struct LidarNoise {
  double range_sigma_m = 0.02;        ///< Gaussian range noise
  double angular_jitter_deg = 0.01;   ///< Gaussian jitter of each beam's direction
  double dropout_probability = 0.02;  ///< chance that a return is lost
  double beam_divergence_mrad = 2.0;  ///< beam footprint; edges within it give mixed points
};

/// One beam of a scan pattern.
struct Beam {
  float azimuth_rad = 0.0f;    ///< atan2(y, x) in the LiDAR frame
  float elevation_rad = 0.0f;  ///< asin(z / r)
  int16_t ring = -1;           ///< laser channel, -1 for ringless sensors
  int32_t time_offset_us = 0;  ///< firing time after the frame start
};

/// Points of one sweep as a struct of arrays; capacity reserved once and reused.
struct LidarScan {
  std::vector<float> x, y, z, intensity;  ///< LiDAR frame at firing time, metres
  std::vector<int16_t> ring;
  std::vector<int32_t> time_offset_us;
  std::vector<int16_t> board;  ///< truth: index into Scene::boards hit, -1 otherwise
  void Reserve(size_t n);
  void Clear();
  size_t size() const { return x.size(); }
};

/// The scan pattern of a LiDAR kind, as beams in firing order over one frame (1 / frame_rate_hz).
/// `frame_index` lets MEMS patterns shift from frame to frame as real ones do.
void MakeScanPattern(const LidarModel& model, int frame_index, std::vector<Beam>* beams);

class LidarSimulator {
 public:
  LidarSimulator(const LidarModel& model, const LidarNoise& noise);

  /// Casts one sweep. The sensor moves from T_world_lidar_start (at time offset 0) to
  /// T_world_lidar_end (at 1 / frame_rate_hz), interpolated per beam; each point is expressed in
  /// the LiDAR frame at its own firing time, as a real sensor reports it. Deterministic for a seed.
  void Scan(const Scene& scene, const Pose& T_world_lidar_start, const Pose& T_world_lidar_end,
            int frame_index, uint64_t seed, LidarScan* out);

  const LidarModel& model() const { return model_; }

 private:
  LidarModel model_;
  LidarNoise noise_;
  std::vector<Beam> beams_;  ///< reused between frames
};

}  // namespace calibd::sim
