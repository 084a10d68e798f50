#include "calibd/core/lidar/lidar_model.hpp"

#include <algorithm>
#include <iterator>

namespace calibd {

namespace {

// The one table of model names.
struct NamedKind {
  const char* name;
  LidarKind kind;
};
constexpr NamedKind kLidarNames[] = {
    {"ot128", LidarKind::kOt128}, {"m1", LidarKind::kM1},         {"falcon", LidarKind::kFalcon},
    {"vlp16", LidarKind::kVlp16}, {"vlp32c", LidarKind::kVlp32c}, {"os1-64", LidarKind::kOs1_64},
    {"avia", LidarKind::kAvia},   {"mid360", LidarKind::kMid360}, {"generic", LidarKind::kGeneric},
};

}  // namespace

bool LidarKindFromName(const std::string& name, LidarKind* kind, std::string* error) {
  for (const NamedKind& n : kLidarNames) {
    if (name == n.name) {
      *kind = n.kind;
      return true;
    }
  }
  if (error)
    *error = "unknown LiDAR model '" + name + "' (expected one of " + LidarModelNames() + ")";
  return false;
}

std::string LidarModelNames() {
  std::string out;
  for (const NamedKind& n : kLidarNames) out += (out.empty() ? "" : ", ") + std::string(n.name);
  return out;
}

std::vector<LidarKind> SimulatedLidarKinds() {
  std::vector<LidarKind> out;
  for (const NamedKind& n : kLidarNames)
    if (n.kind != LidarKind::kGeneric) out.push_back(n.kind);
  return out;
}

namespace {

// Vertical angle (elevation, degrees, upward positive) of each of the 128 channels of a Hesai
// Pandar128E3X/E4X, channel 1 (top) first, i.e. in the channel order of the point cloud packet.
// Source: the nominal per-channel elevation table that Hesai publishes with its Pandar128 SDK
// (github.com/HesaiTechnology/HesaiLidar_Swift_SDK, default correction table), which matches the
// "Channel Distribution" appendix of the Pandar128E4X user manual: 14.436 deg at the top, -25.016
// deg at the bottom, and a central band from +2.0 to -6.1 deg with ~0.125 deg spacing. A real unit
// ships its own calibrated table; these design values are what we simulate.
constexpr double kPandar128ElevationDeg[128] = {
    14.436,  13.535,  13.080,  12.624,  12.163,  11.702,  11.237,  10.771,  10.301,  9.830,
    9.355,   8.880,   8.401,   7.921,   7.437,   6.954,   6.467,   5.980,   5.487,   4.997,
    4.501,   4.009,   3.509,   3.014,   2.512,   2.014,   1.885,   1.761,   1.637,   1.511,
    1.386,   1.258,   1.130,   1.009,   0.880,   0.756,   0.630,   0.505,   0.379,   0.251,
    0.124,   0.000,   -0.129,  -0.254,  -0.380,  -0.506,  -0.632,  -0.760,  -0.887,  -1.012,
    -1.141,  -1.266,  -1.393,  -1.519,  -1.646,  -1.773,  -1.901,  -2.027,  -2.155,  -2.282,
    -2.409,  -2.535,  -2.662,  -2.789,  -2.916,  -3.044,  -3.172,  -3.299,  -3.425,  -3.552,
    -3.680,  -3.806,  -3.933,  -4.062,  -4.190,  -4.318,  -4.444,  -4.571,  -4.698,  -4.824,
    -4.951,  -5.081,  -5.209,  -5.336,  -5.463,  -5.589,  -5.717,  -5.843,  -5.968,  -6.099,
    -6.607,  -7.118,  -7.624,  -8.135,  -8.640,  -9.149,  -9.652,  -10.160, -10.664, -11.170,
    -11.670, -12.174, -12.672, -13.173, -13.668, -14.166, -14.658, -15.154, -15.643, -16.135,
    -16.620, -17.108, -17.590, -18.073, -18.548, -19.031, -19.501, -19.981, -20.445, -20.920,
    -21.379, -21.850, -22.304, -22.770, -23.219, -23.680, -24.123, -25.016,
};

LidarModel MakeOt128() {
  LidarModel m;
  m.kind = LidarKind::kOt128;
  m.name = "ot128";
  m.has_rings = true;
  m.ring_elevation_deg.assign(std::begin(kPandar128ElevationDeg), std::end(kPandar128ElevationDeg));
  // 10 Hz spin with 0.2 deg firing steps (manual: 0.2 deg horizontal resolution at 10 Hz in
  // standard mode) gives 1800 columns of 128 firings.
  m.azimuth_resolution_deg = 0.2;
  m.elevation_resolution_deg = 0.125;  // finest channel spacing, in the central band
  m.azimuth_min_deg = -180.0;
  m.azimuth_max_deg = 180.0;
  m.elevation_min_deg = *std::min_element(m.ring_elevation_deg.begin(), m.ring_elevation_deg.end());
  m.elevation_max_deg = *std::max_element(m.ring_elevation_deg.begin(), m.ring_elevation_deg.end());
  m.min_range_m = 0.3;             // manual: 0.3 m minimum range
  m.max_range_m = 200.0;           // 200 m at 10% reflectivity
  m.range_quantization_m = 0.004;  // packet distance unit: 4 mm
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = 1800 * 128;  // 230,400 single-return firings
  return m;
}

LidarModel MakeM1() {
  LidarModel m;
  m.kind = LidarKind::kM1;
  m.name = "m1";
  m.has_rings = false;  // 5 lasers each raster-scanned by a MEMS mirror: no fixed rows
  // RS-LiDAR-M1 user guide / datasheet: 120 x 25 deg FOV built from 5 laser zones side by side,
  // 0.2 deg average resolution both ways, 10 Hz, ~787,500 points/s single return, 5 mm distance
  // resolution in the MSOP packet, 0.5 m to 200 m.
  m.azimuth_resolution_deg = 0.2;
  m.elevation_resolution_deg = 0.2;
  m.azimuth_min_deg = -60.0;
  m.azimuth_max_deg = 60.0;
  m.elevation_min_deg = -12.5;
  m.elevation_max_deg = 12.5;
  m.min_range_m = 0.5;
  m.max_range_m = 200.0;
  m.range_quantization_m = 0.005;
  m.frame_rate_hz = 10.0;
  // 5 zones x 126 fast-axis lines x 125 samples (the simulator's raster, lidar_sim.cpp).
  m.nominal_points_per_frame = 5 * 126 * 125;  // 78,750
  return m;
}

LidarModel MakeFalcon() {
  LidarModel m;
  m.kind = LidarKind::kFalcon;
  m.name = "falcon";
  m.has_rings = false;  // galvo lines are not fixed channels; no ring index is reported
  // Seyond (Innovusion) Falcon-like: a rotating polygon sweeps each line horizontally over
  // 120 deg, a galvanometer steps the line vertically over ~25 deg and packs lines densely
  // around the horizon (the "region of interest" of the datasheets, ~0.06-0.1 deg there).
  // The simulator's pattern (lidar_sim.cpp): lines every 0.075 deg within +-3 deg of the
  // horizon, every 0.2 deg outside (175 lines), 750 samples per line (0.16 deg), 10 Hz:
  // 131,250 points per frame, inside the 100k-150k typical of the sensor at 10 Hz.
  m.azimuth_resolution_deg = 0.16;
  m.elevation_resolution_deg = 0.075;
  m.azimuth_min_deg = -60.0;
  m.azimuth_max_deg = 60.0;
  m.elevation_min_deg = -12.5;
  m.elevation_max_deg = 12.5;
  m.min_range_m = 0.5;
  m.max_range_m = 250.0;
  m.range_quantization_m = 0.0025;
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = 175 * 750;  // 131,250
  return m;
}

// A spinning LiDAR of `rings` (elevations, degrees) and `columns` firings per turn.
LidarModel MakeSpinning(LidarKind kind, const char* name, std::vector<double> rings, int columns) {
  LidarModel m;
  m.kind = kind;
  m.name = name;
  m.has_rings = true;
  m.ring_elevation_deg = std::move(rings);
  m.azimuth_resolution_deg = 360.0 / columns;
  m.azimuth_min_deg = -180.0;
  m.azimuth_max_deg = 180.0;
  m.elevation_min_deg = *std::min_element(m.ring_elevation_deg.begin(), m.ring_elevation_deg.end());
  m.elevation_max_deg = *std::max_element(m.ring_elevation_deg.begin(), m.ring_elevation_deg.end());
  std::vector<double> sorted = m.ring_elevation_deg;
  std::sort(sorted.begin(), sorted.end());
  m.elevation_resolution_deg = 1e9;
  for (size_t i = 1; i < sorted.size(); ++i)
    m.elevation_resolution_deg = std::min(m.elevation_resolution_deg, sorted[i] - sorted[i - 1]);
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = columns * static_cast<int>(m.ring_elevation_deg.size());
  return m;
}

// Velodyne VLP-16 (datasheet 63-9229 and user manual 63-9243): 16 lasers from -15 to +15 deg in 2
// deg steps (listed in firing order, as the packets carry them: -15, 1, -13, 3, ...), 0.2 deg
// azimuth steps at 10 Hz (1800 firings a turn, ~300,000 points/s), 100 m, +-3 cm typical accuracy,
// 2 mm distance units in the packet.
LidarModel MakeVlp16() {
  std::vector<double> rings;
  for (int i = 0; i < 16; ++i) rings.push_back(i % 2 == 0 ? -15.0 + i : 1.0 + (i - 1));
  LidarModel m = MakeSpinning(LidarKind::kVlp16, "vlp16", rings, 1800);
  m.min_range_m = 0.5;
  m.max_range_m = 100.0;
  m.range_quantization_m = 0.002;
  return m;
}

// Velodyne VLP-32C (user manual 63-9325, "VLP-32C laser angles"): 32 lasers over -25..+15 deg,
// packed around the horizon (0.33 deg apart from -4 to +1.7 deg), in firing order; 0.2 deg
// azimuth steps at 10 Hz (~600,000 points/s), 200 m, +-3 cm, 4 mm distance units.
constexpr double kVlp32cElevationDeg[32] = {
    -25.0,  -1.0,   -1.667, -15.639, -11.31, 0.0,    -0.667, -8.843, -7.254, 0.333,  -0.333,
    -6.148, -5.333, 1.333,  0.667,   -4.0,   -4.667, 1.667,  1.0,    -3.667, -3.333, 3.333,
    2.333,  -2.667, -3.0,   7.0,     4.667,  -2.333, -2.0,   15.0,   10.333, -1.333,
};

LidarModel MakeVlp32c() {
  LidarModel m =
      MakeSpinning(LidarKind::kVlp32c, "vlp32c",
                   {std::begin(kVlp32cElevationDeg), std::end(kVlp32cElevationDeg)}, 1800);
  m.min_range_m = 0.5;
  m.max_range_m = 200.0;
  m.range_quantization_m = 0.004;
  return m;
}

// Ouster OS1-64 (OS1 datasheet, rev 6/7): 64 channels evenly spread over a 45 deg vertical field
// (+22.5..-22.5 deg, 0.71 deg apart), 1024 columns at 10 Hz (the default "1024x10" mode),
// 0.5 m minimum and ~120 m range, +-1.5-5 cm precision, 1 mm range resolution. A real unit
// staggers its beams in azimuth by a few degrees; the driver's destaggered cloud and its ring
// field are what we read.
LidarModel MakeOs1_64() {
  std::vector<double> rings;
  for (int i = 0; i < 64; ++i) rings.push_back(22.5 - i * 45.0 / 63.0);
  LidarModel m = MakeSpinning(LidarKind::kOs1_64, "os1-64", rings, 1024);
  m.min_range_m = 0.5;
  m.max_range_m = 120.0;
  m.range_quantization_m = 0.001;
  return m;
}

// Livox-Avia-like (Avia datasheet): non-repetitive scanning over a 70.4 x 77.2 deg field, 240,000
// points/s (first return; 24,000 a 10 Hz frame), 2 cm range precision, angular precision under
// 0.05 deg, 1 mm range units; returns from about 1 m. No scan lines: in one frame the rosette's
// petals cross the field about 0.4 deg apart on average (densest at the centre), so the range
// image bins are 0.4 deg and the segmentation bridges the empty ones.
LidarModel MakeAvia() {
  LidarModel m;
  m.kind = LidarKind::kAvia;
  m.name = "avia";
  m.has_rings = false;
  m.azimuth_resolution_deg = 0.4;
  m.elevation_resolution_deg = 0.4;
  m.azimuth_min_deg = -35.2;
  m.azimuth_max_deg = 35.2;
  m.elevation_min_deg = -38.6;
  m.elevation_max_deg = 38.6;
  m.min_range_m = 1.0;
  m.max_range_m = 190.0;  // at 10% reflectivity
  m.range_quantization_m = 0.001;
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = 24000;
  m.non_repetitive = true;
  return m;
}

// Livox-Mid-360-like (Mid-360 user manual): 360 deg around, -7..+52 deg vertically, 200,000
// points/s (20,000 a 10 Hz frame), non-repetitive, 0.1 m blind zone, 40 m at 10% reflectivity,
// <= 2 cm range precision, angular precision under 0.15 deg, 1 mm range units. About one point a
// square degree per frame: 1 deg bins.
LidarModel MakeMid360() {
  LidarModel m;
  m.kind = LidarKind::kMid360;
  m.name = "mid360";
  m.has_rings = false;
  m.azimuth_resolution_deg = 1.0;
  m.elevation_resolution_deg = 1.0;
  m.azimuth_min_deg = -180.0;
  m.azimuth_max_deg = 180.0;
  m.elevation_min_deg = -7.0;
  m.elevation_max_deg = 52.0;
  m.min_range_m = 0.1;
  m.max_range_m = 70.0;  // 40 m at 10% reflectivity, 70 m at 80%
  m.range_quantization_m = 0.001;
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = 20000;
  m.non_repetitive = true;
  return m;
}

LidarModel MakeGenericPlaceholder() {
  LidarModel m;
  m.kind = LidarKind::kGeneric;
  m.name = "generic";
  m.has_rings = false;  // rows are elevation bins even when the cloud carries a ring field
  m.azimuth_resolution_deg = 0.2;
  m.elevation_resolution_deg = 0.2;
  m.azimuth_min_deg = -180.0;
  m.azimuth_max_deg = 180.0;
  m.elevation_min_deg = -25.0;
  m.elevation_max_deg = 15.0;
  m.min_range_m = 0.3;
  m.max_range_m = 200.0;
  m.range_quantization_m = 0.005;
  m.frame_rate_hz = 10.0;
  m.nominal_points_per_frame = 200000;
  return m;
}

}  // namespace

LidarModel MakeLidarModel(LidarKind kind) {
  switch (kind) {
    case LidarKind::kOt128:
      return MakeOt128();
    case LidarKind::kM1:
      return MakeM1();
    case LidarKind::kFalcon:
      return MakeFalcon();
    case LidarKind::kVlp16:
      return MakeVlp16();
    case LidarKind::kVlp32c:
      return MakeVlp32c();
    case LidarKind::kOs1_64:
      return MakeOs1_64();
    case LidarKind::kAvia:
      return MakeAvia();
    case LidarKind::kMid360:
      return MakeMid360();
    case LidarKind::kGeneric:
      return MakeGenericPlaceholder();
  }
  return MakeOt128();
}

}  // namespace calibd
