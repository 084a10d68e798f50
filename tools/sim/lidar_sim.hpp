#pragma once
/// \file
/// Simulates one LiDAR sweep over a Scene: the sensor's scan pattern, motion during the sweep,
/// range noise and quantization, angular jitter, dropouts, mixed points at depth edges.

#include <cstdint>
#include <vector>

#include "calibd/core/lidar/lidar_model.hpp"
#include "scene.hpp"

namespace calibd::sim {

struct LidarNoise {
  double range_sigma_m = 0.02;        ///< Gaussian range noise
  double angular_jitter_deg = 0.01;   ///< Gaussian jitter of each beam's direction
  double dropout_probability = 0.02;  ///< chance that a return is lost
  double beam_divergence_mrad = 2.0;  ///< beam footprint; edges within it give mixed points
  /// When a footprint straddles surfaces more than `mixed_point_min_gap_m` apart, the chance that
  /// the sensor reports one blended ("ghost") range between them instead of the nearest surface.
  /// 0 disables mixed points; the footprint still picks the nearest surface at edges.
  double mixed_point_probability = 0.5;
  double mixed_point_min_gap_m = 0.3;  ///< depth gap within a footprint that can give a mixed point
  /// Constant added to every range (a miscalibrated range offset; real 16-ring units are often
  /// 2-3 cm off): a fault to inject, 0 on a healthy sensor.
  double range_bias_m = 0.0;
  /// Per laser (index: ring), how much higher than the model's table the beam fires, deg: a wrong
  /// or aged intrinsic table (a fault to inject). The points are still reported along the
  /// table's direction, so a flat board comes out stepped. Empty: none; ringless patterns ignore
  /// it.
  std::vector<double> ring_elevation_error_deg;
};

struct PatternShape;  // lidar_sim.cpp: which beams neighbour which in a scan pattern

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
  /// the LiDAR frame at its own firing time, as a real sensor reports it (not motion compensated).
  /// Each beam is cast along its jittered direction and reported along its nominal one (the
  /// encoder/mirror reading), so jitter shows up as angular noise of the points. Work is split in
  /// fixed chunks with one random stream each and run on up to 2 threads: the output depends on
  /// the seed and inputs only. Rotation is slerped at most every 20 us of firing time.
  /// Deterministic for a seed.
  void Scan(const Scene& scene, const Pose& T_world_lidar_start, const Pose& T_world_lidar_end,
            int frame_index, uint64_t seed, LidarScan* out);
  /// The same over a scene that changes during the sweep (boards carried past a standing
  /// sensor): `slices` are the scene at equal shares of the sweep's time, each beam cast into
  /// the one of its firing time. The slices must list the same primitives.
  void Scan(const std::vector<const Scene*>& slices, const Pose& T_world_lidar_start,
            const Pose& T_world_lidar_end, int frame_index, uint64_t seed, LidarScan* out);

  const LidarModel& model() const { return model_; }

 private:
  /// Per-beam state shared by the two passes of Scan (main rays, then edges and output).
  struct BeamState {
    float dir[3];       ///< true (jittered) beam direction, LiDAR frame at firing time
    float t;            ///< main-ray hit distance, m; < 0 when missed (dropped beams are cast)
    float intensity;    ///< of the main-ray hit
    int32_t primitive;  ///< main-ray hit primitive, -1 when missed
    bool dropped;
  };
  struct BeamOut {
    float x, y, z, intensity;
    int16_t board;
    bool valid;
  };

  void RebuildPatternIfNeeded(int frame_index);
  /// Which of Scan's slices beam i is cast into.
  size_t SliceOf(size_t i) const;
  void CastMainRays(const Pose& T_world_lidar_start, const Pose& T_world_lidar_end, uint64_t seed,
                    size_t chunk);
  void FinishBeams(const Pose& T_world_lidar_start, const Pose& T_world_lidar_end,
                   const PatternShape& shape, uint64_t seed, size_t chunk);

  LidarModel model_;
  LidarNoise noise_;
  std::vector<Beam> beams_;              ///< reused between frames
  std::vector<float> nominal_dir_;       ///< 3 per beam: reported direction (LiDAR frame)
  std::vector<float> fired_dir_;         ///< 3 per beam: where it fires (ring_elevation_error_deg)
  int pattern_key_ = -1;                 ///< which frame phase beams_ holds, -1 before the first
  std::vector<BeamState> state_;         ///< reused between frames
  std::vector<BeamOut> out_;             ///< reused between frames
  std::vector<const Scene*> slices_;     ///< the scan's scene(s), during Scan only
  std::vector<AzimuthSectors> sectors_;  ///< per slice, for the scan's path
};

}  // namespace calibd::sim
