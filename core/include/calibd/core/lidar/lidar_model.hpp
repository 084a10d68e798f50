#pragma once
/// \file
/// What calibd knows of a LiDAR's scan geometry: enough to build a range image (paper §III-C-1)
/// and, in the simulator, to generate its scan pattern. LiDAR frame: x forward, y left, z up.

#include <string>
#include <vector>

namespace calibd {

enum class LidarKind {
  kOt128,   ///< Hesai OT128-like mechanical spinning LiDAR, 128 rings (Pandar128E4X table)
  kM1,      ///< RoboSense M1-like MEMS LiDAR: 5 lasers, ~120x25 deg, no rings
  kFalcon,  ///< Seyond/Innovusion Falcon-like polygon-mirror LiDAR, denser central band, no rings
  kVlp16,   ///< Velodyne VLP-16 (Puck): 16 rings 2 deg apart over +-15 deg
  kVlp32c,  ///< Velodyne VLP-32C: 32 rings over -25..+15 deg, densest around the horizon
  kOs1_64,  ///< Ouster OS1-64: 64 evenly spaced rings over +-22.5 deg, 1024 columns
  kAvia,    ///< Livox-Avia-like: 6 lasers behind Risley prisms, non-repetitive rosette, no rings
  kMid360,  ///< Livox-Mid-360-like: 360 deg spin with a non-repetitive vertical sweep, no rings
  /// Any sensor described only by its point cloud (no ring, unknown pattern): resolution and field
  /// of view are estimated from its frames or set in the config (lidar_resolution.hpp).
  kGeneric,
};

struct LidarModel {
  LidarKind kind = LidarKind::kOt128;
  std::string name;                        ///< as LidarKindFromName() parses it
  bool has_rings = true;                   ///< ring index is meaningful (row of the range image)
  std::vector<double> ring_elevation_deg;  ///< per ring index, degrees (empty without rings)
  double azimuth_resolution_deg = 0.2;     ///< horizontal angular step of the pattern
  double elevation_resolution_deg =
      0.125;                        ///< finest vertical step (range-image row size w/o rings)
  double azimuth_min_deg = -180.0;  ///< horizontal field of view (azimuth = atan2(y, x))
  double azimuth_max_deg = 180.0;
  double elevation_min_deg = -25.0;  ///< vertical field of view
  double elevation_max_deg = 15.0;
  double min_range_m = 0.3;
  double max_range_m = 200.0;
  double range_quantization_m = 0.004;  ///< range resolution of the sensor
  double frame_rate_hz = 10.0;
  int nominal_points_per_frame = 0;  ///< typical returns per frame (for buffer sizing)
  /// No fixed beam grid (Livox's rosettes, the Mid-360's sweep): within one frame the beams fall
  /// irregularly, about nominal_points_per_frame over the field of view, so a range-image cell
  /// holds none, one or several. Reference boards are then sampled at random at that density.
  bool non_repetitive = false;
  /// Returns of one frame over the field of view, for a non-repetitive pattern's density; 0:
  /// nominal_points_per_frame (which a generic model sizes its buffers with instead).
  int pattern_points_per_frame = 0;
};

/// Parses a model name (LidarModelNames()). Returns false and sets `error`, listing the names, for
/// any other.
bool LidarKindFromName(const std::string& name, LidarKind* kind, std::string* error);

/// Every model name, comma-separated ("ot128, m1, ..., generic"): for errors and --help.
std::string LidarModelNames();

/// The models the simulator has a scan pattern for (every kind but kGeneric).
std::vector<LidarKind> SimulatedLidarKinds();

/// The built-in description of a LiDAR kind. For kGeneric only a ringless placeholder (0.2 deg,
/// 360 x 40 deg): use MakeGenericLidarModel() with the estimate or the config's values.
LidarModel MakeLidarModel(LidarKind kind);

}  // namespace calibd
