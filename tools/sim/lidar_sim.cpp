#include "lidar_sim.hpp"

#include <algorithm>
#include <cmath>
#include <opencv2/core.hpp>
#include <thread>

#include "opencv_rng.hpp"

namespace calibd::sim {

// Layout of a pattern, for PatternNeighbours().
struct PatternShape {
  LidarKind kind = LidarKind::kOt128;
  int rings = 0, columns = 0;               // spinning
  std::vector<int> ring_below, ring_above;  // spinning: next ring down/up in elevation, or -1
  int lasers = 0;                           // avia, mid360
};

void LidarScan::Reserve(size_t n) {
  x.reserve(n);
  y.reserve(n);
  z.reserve(n);
  intensity.reserve(n);
  ring.reserve(n);
  time_offset_us.reserve(n);
  board.reserve(n);
}

void LidarScan::Clear() {
  x.clear();
  y.clear();
  z.clear();
  intensity.clear();
  ring.clear();
  time_offset_us.clear();
  board.clear();
}

namespace {

// Pattern layouts. Beam index formulas (used again to find a beam's neighbours in the pattern):
//   spinning (ot128, vlp16, vlp32c, os1-64): i = column * rings + ring
//   m1:     i = (line * kM1Samples + sample) * kM1Zones + zone
//   falcon: i = line * kFalconSamples + sample
//   avia, mid360: i = sample * lasers + laser (the lasers fire together)
// Channels of one column do not fire at once (the manuals' firing-time tables spread them over
// the block); we spread them evenly over the first 80% of the column period.
constexpr double kRingSpreadFraction = 0.8;
constexpr int kAviaLasers = 6;
constexpr int kMid360Lasers = 4;

constexpr int kM1Zones = 5;
constexpr int kM1Lines = 126;    // fast-axis sweeps per zone and frame
constexpr int kM1Samples = 125;  // firings per sweep
constexpr double kM1ZoneWidthDeg = 24.0;

constexpr int kFalconSamples = 750;  // 120 deg / 0.16 deg
constexpr double kFalconBandDeg = 3.0;
constexpr double kFalconBandStepDeg = 0.075;
constexpr double kFalconOuterStepDeg = 0.2;

// Fractional part in [0, 1).
double Frac(double v) { return v - std::floor(v); }

// Frame phase of the MEMS raster: successive frames shift the raster by a low-discrepancy
// fraction of a sample/line so that they interleave, as real MEMS patterns drift frame to frame.
int M1PhaseKey(int frame_index) { return ((frame_index % 16) + 16) % 16; }

bool IsSpinning(const LidarModel& m) { return m.has_rings && !m.ring_elevation_deg.empty(); }

PatternShape ShapeOf(const LidarModel& m) {
  PatternShape s;
  s.kind = m.kind;
  if (IsSpinning(m)) {
    s.rings = static_cast<int>(m.ring_elevation_deg.size());
    s.columns = static_cast<int>(std::lround(360.0 / m.azimuth_resolution_deg));
    std::vector<int> order(s.rings);
    for (int r = 0; r < s.rings; ++r) order[r] = r;
    std::sort(order.begin(), order.end(),
              [&](int a, int b) { return m.ring_elevation_deg[a] < m.ring_elevation_deg[b]; });
    s.ring_below.assign(s.rings, -1);
    s.ring_above.assign(s.rings, -1);
    for (int k = 0; k < s.rings; ++k) {
      if (k > 0) s.ring_below[order[k]] = order[k - 1];
      if (k + 1 < s.rings) s.ring_above[order[k]] = order[k + 1];
    }
  }
  if (m.kind == LidarKind::kAvia) s.lasers = kAviaLasers;
  if (m.kind == LidarKind::kMid360) s.lasers = kMid360Lasers;
  return s;
}

void MakeSpinningPattern(const LidarModel& model, double period_us, std::vector<Beam>* beams) {
  const PatternShape shape = ShapeOf(model);
  const double column_us = period_us / shape.columns;
  const double spread_us = kRingSpreadFraction * column_us;
  for (int col = 0; col < shape.columns; ++col) {
    // Hesai and Velodyne spin clockwise seen from above, so azimuth = atan2(y, x) decreases with
    // time; the frame starts and ends behind the sensor (+-180 deg) so nothing in front is split.
    const double az_deg = 180.0 - model.azimuth_resolution_deg * col;
    const float az = static_cast<float>(az_deg * kDeg2Rad);
    const double t0 = col * column_us;
    for (int ring = 0; ring < shape.rings; ++ring) {
      Beam b;
      b.azimuth_rad = az;
      b.elevation_rad = static_cast<float>(model.ring_elevation_deg[ring] * kDeg2Rad);
      b.ring = static_cast<int16_t>(ring);
      b.time_offset_us = static_cast<int>(std::floor(t0 + spread_us * ring / shape.rings));
      beams->push_back(b);
    }
  }
}

// Livox-Avia-like rosette: each laser looks through two wedge prisms turning in opposite
// directions (a Risley pair, Livox's published design), so its direction is the sum of two
// rotating deflections: a line through the centre that swings back and forth at (f1 + f2) / 2
// while it turns at (f1 - f2) / 2. The prism rates are incommensurate, so the pattern never
// repeats and each frame fills other gaps. Laser l's pattern is turned by l * 180 / lasers deg.
// Time runs on across frames: frame k continues where frame k - 1 ended.
constexpr double kAviaPrism1Hz = 120.3, kAviaPrism2Hz = 78.9;

void MakeAviaPattern(const LidarModel& model, int frame_index, double period_us,
                     std::vector<Beam>* beams) {
  const int samples = model.nominal_points_per_frame / kAviaLasers;
  const double dt_us = period_us / samples;
  const double half_az = 0.5 * (model.azimuth_max_deg - model.azimuth_min_deg);
  const double half_el = 0.5 * (model.elevation_max_deg - model.elevation_min_deg);
  for (int k = 0; k < samples; ++k) {
    const double t = (frame_index * period_us + k * dt_us) * 1e-6;
    const double a = 2.0 * M_PI * kAviaPrism1Hz * t, b = -2.0 * M_PI * kAviaPrism2Hz * t;
    const double u0 = 0.5 * (std::cos(a) + std::cos(b)), v0 = 0.5 * (std::sin(a) + std::sin(b));
    for (int l = 0; l < kAviaLasers; ++l) {
      const double r = M_PI * l / kAviaLasers;
      const double u = std::cos(r) * u0 - std::sin(r) * v0, v = std::sin(r) * u0 + std::cos(r) * v0;
      Beam beam;
      beam.azimuth_rad = static_cast<float>(u * half_az * kDeg2Rad);
      beam.elevation_rad = static_cast<float>(v * half_el * kDeg2Rad);
      beam.ring = -1;
      beam.time_offset_us = static_cast<int>(std::floor(k * dt_us));
      beams->push_back(beam);
    }
  }
}

// Livox-Mid-360-like: the head turns once a frame while each of 4 lasers, 90 deg apart, sweeps the
// vertical field up and down ~45 times a turn; the sweep's rate is incommensurate with the turn, so
// successive frames cross the field at other azimuths.
constexpr double kMid360SweepHz = 447.3;

void MakeMid360Pattern(const LidarModel& model, int frame_index, double period_us,
                       std::vector<Beam>* beams) {
  const int samples = model.nominal_points_per_frame / kMid360Lasers;
  const double dt_us = period_us / samples;
  const double mid = 0.5 * (model.elevation_max_deg + model.elevation_min_deg);
  const double half = 0.5 * (model.elevation_max_deg - model.elevation_min_deg);
  for (int k = 0; k < samples; ++k) {
    const double t = (frame_index * period_us + k * dt_us) * 1e-6;
    const double turn_deg = 360.0 * k / samples;
    for (int l = 0; l < kMid360Lasers; ++l) {
      const double az = std::remainder(turn_deg + 90.0 * l, 360.0);
      const double el = mid + half * std::sin(2.0 * M_PI * kMid360SweepHz * t + 0.5 * M_PI * l);
      Beam beam;
      beam.azimuth_rad = static_cast<float>(az * kDeg2Rad);
      beam.elevation_rad = static_cast<float>(el * kDeg2Rad);
      beam.ring = -1;
      beam.time_offset_us = static_cast<int>(std::floor(k * dt_us));
      beams->push_back(beam);
    }
  }
}

void MakeM1Pattern(const LidarModel& model, int frame_index, double period_us,
                   std::vector<Beam>* beams) {
  const int key = M1PhaseKey(frame_index);
  const double phase_v = Frac(key * 0.6180339887498949);        // of a line spacing, [0, 1)
  const double phase_h = Frac(key * 0.7548776662466927) - 0.5;  // of a sample, [-0.5, 0.5)
  const double el_top = model.elevation_max_deg;
  const double line_deg = (model.elevation_max_deg - model.elevation_min_deg) / kM1Lines;
  const double half_width = 0.5 * kM1ZoneWidthDeg;
  const double dt_us = period_us / (kM1Lines * kM1Samples);
  for (int line = 0; line < kM1Lines; ++line) {
    // The resonant fast axis sweeps back and forth: odd lines run right to left.
    const double dir = (line % 2 == 0) ? 1.0 : -1.0;
    for (int k = 0; k < kM1Samples; ++k) {
      const double u = (k + 0.5 + phase_h) / kM1Samples;  // (0, 1): time within the sweep
      // Sinusoidal mirror angle sampled uniformly in time: points bunch at the sweep edges.
      const double az_local = -dir * half_width * std::cos(M_PI * u);
      // The slow axis moves continuously; half a line spacing of it falls within one sweep.
      const double el = el_top - line_deg * (line + 0.5 * u + 0.5 * phase_v);
      const int t = static_cast<int>(std::floor((line * kM1Samples + k) * dt_us));
      for (int zone = 0; zone < kM1Zones; ++zone) {
        // All five lasers fire together, each in its own 24 deg zone, left to right.
        const double centre = model.azimuth_min_deg + (zone + 0.5) * kM1ZoneWidthDeg;
        Beam b;
        b.azimuth_rad = static_cast<float>((centre + az_local) * kDeg2Rad);
        b.elevation_rad = static_cast<float>(el * kDeg2Rad);
        b.ring = -1;
        b.time_offset_us = t;
        beams->push_back(b);
      }
    }
  }
}

// Galvo line elevations, top to bottom: 0.2 deg steps outside +-3 deg, 0.075 deg inside.
std::vector<double> FalconLineElevationsDeg() {
  std::vector<double> el;
  const int outer = static_cast<int>(std::lround((12.4 - kFalconBandDeg) / kFalconOuterStepDeg));
  const int band = static_cast<int>(std::lround(2.0 * kFalconBandDeg / kFalconBandStepDeg));
  for (int i = outer; i >= 1; --i) el.push_back(kFalconBandDeg + i * kFalconOuterStepDeg);
  for (int i = 0; i <= band; ++i) el.push_back(kFalconBandDeg - i * kFalconBandStepDeg);
  for (int i = 1; i <= outer; ++i) el.push_back(-kFalconBandDeg - i * kFalconOuterStepDeg);
  return el;
}

void MakeFalconPattern(const LidarModel& model, double period_us, std::vector<Beam>* beams) {
  const std::vector<double> lines = FalconLineElevationsDeg();
  const double step = (model.azimuth_max_deg - model.azimuth_min_deg) / kFalconSamples;
  const double dt_us = period_us / (static_cast<double>(lines.size()) * kFalconSamples);
  for (size_t line = 0; line < lines.size(); ++line) {
    const float el = static_cast<float>(lines[line] * kDeg2Rad);
    for (int k = 0; k < kFalconSamples; ++k) {
      // Each polygon facet sweeps the full width at constant angular speed, always the same way.
      Beam b;
      b.azimuth_rad = static_cast<float>((model.azimuth_min_deg + (k + 0.5) * step) * kDeg2Rad);
      b.elevation_rad = el;
      b.ring = -1;
      b.time_offset_us =
          static_cast<int>(std::floor((static_cast<double>(line) * kFalconSamples + k) * dt_us));
      beams->push_back(b);
    }
  }
}

// Indices of the beams next to beam i in the pattern (same line/ring, and the adjacent ones).
int PatternNeighbours(const PatternShape& shape, int i, int n, int out[4]) {
  int c = 0;
  switch (shape.kind) {
    case LidarKind::kOt128:
    case LidarKind::kVlp16:
    case LidarKind::kVlp32c:
    case LidarKind::kOs1_64: {
      const int rings = shape.rings, columns = shape.columns;
      const int col = i / rings, ring = i % rings;
      out[c++] = ((col + 1) % columns) * rings + ring;  // the sweep wraps around
      out[c++] = ((col + columns - 1) % columns) * rings + ring;
      // Rings are in firing order: the ones above and below in elevation come from the table.
      if (shape.ring_below[ring] >= 0) out[c++] = col * rings + shape.ring_below[ring];
      if (shape.ring_above[ring] >= 0) out[c++] = col * rings + shape.ring_above[ring];
      break;
    }
    case LidarKind::kAvia:
    case LidarKind::kMid360: {
      // Along the laser's track; the tracks next to it are not at a fixed index.
      if (i >= shape.lasers) out[c++] = i - shape.lasers;
      if (i + shape.lasers < n) out[c++] = i + shape.lasers;
      break;
    }
    case LidarKind::kM1: {
      const int zone = i % kM1Zones, s = i / kM1Zones;
      const int line = s / kM1Samples, k = s % kM1Samples;
      if (k > 0) out[c++] = i - kM1Zones;
      if (k + 1 < kM1Samples) out[c++] = i + kM1Zones;
      // Sweeps alternate direction: the sample below/above at the same azimuth is mirrored.
      const int mk = kM1Samples - 1 - k;
      if (line > 0) out[c++] = ((line - 1) * kM1Samples + mk) * kM1Zones + zone;
      if (line + 1 < kM1Lines) out[c++] = ((line + 1) * kM1Samples + mk) * kM1Zones + zone;
      break;
    }
    case LidarKind::kFalcon: {
      const int k = i % kFalconSamples;
      if (k > 0) out[c++] = i - 1;
      if (k + 1 < kFalconSamples) out[c++] = i + 1;
      if (i >= kFalconSamples) out[c++] = i - kFalconSamples;
      if (i + kFalconSamples < n) out[c++] = i + kFalconSamples;
      break;
    }
    case LidarKind::kGeneric:  // no pattern to simulate (SessionOptions rejects it)
      break;
  }
  return c;
}

uint64_t SplitMix64(uint64_t x) {
  x += 0x9e3779b97f4a7c15ULL;
  x = (x ^ (x >> 30)) * 0xbf58476d1ce4e5b9ULL;
  x = (x ^ (x >> 27)) * 0x94d049bb133111ebULL;
  return x ^ (x >> 31);
}

// One random stream per (seed, chunk, pass): results do not depend on which thread runs a chunk.
// OpenCV's generator: its normals (a ziggurat) cost much less than std::normal_distribution's
// polar method on std::mt19937_64 (docs/performance-and-reliability.md). Its stream is OpenCV's
// (and its libm's), not fixed by the standard, as the camera's noise is.
class ChunkRng {
 public:
  ChunkRng(uint64_t seed, size_t chunk, int pass)
      : rng_(SplitMix64(seed ^ SplitMix64(chunk * 4 + static_cast<uint64_t>(pass)))) {}
  double Uniform() { return rng_.uniform(0.0, 1.0); }
  double Normal() { return rng_.gaussian(1.0); }

 private:
  cv::RNG rng_;
};

constexpr size_t kChunkBeams = 4096;
// Rotation is re-slerped when the firing time moved by more than this; at 90 deg/s that is an
// error of 0.002 deg, well below the angular jitter. Translation is interpolated per beam.
constexpr int kRotationStepUs = 20;

// The sensor pose at a firing time: lerp of the translation, slerp of the rotation.
class PoseAt {
 public:
  PoseAt(const Pose& start, const Pose& end, double period_us)
      : p0_(start.translation()),
        p1_(end.translation()),
        q0_(start.rotation()),
        q1_(end.rotation()),
        inv_period_(1.0 / period_us),
        rotates_(q0_.angularDistance(q1_) > 1e-12),
        R_(start.rotation()) {}

  void Get(int t_us, Eigen::Vector3d* origin, Eigen::Matrix3d* R) {
    const double s = t_us * inv_period_;
    *origin = (1.0 - s) * p0_ + s * p1_;
    if (rotates_ && (cached_t_ < 0 || std::abs(t_us - cached_t_) > kRotationStepUs)) {
      R_ = q0_.slerp(s, q1_).toRotationMatrix();
      cached_t_ = t_us;
    }
    *R = R_;
  }

 private:
  Eigen::Vector3d p0_, p1_;
  Eigen::Quaterniond q0_, q1_;
  double inv_period_;
  bool rotates_;
  Eigen::Matrix3d R_;
  int cached_t_ = -1;
};

// Unit vectors along increasing azimuth and elevation at direction d (LiDAR frame).
void TangentBasis(const Eigen::Vector3d& d, Eigen::Vector3d* e_az, Eigen::Vector3d* e_el) {
  const double h = std::sqrt(d.x() * d.x() + d.y() * d.y());
  *e_az = Eigen::Vector3d(-d.y() / h, d.x() / h, 0.0);
  *e_el = d.cross(*e_az);
}

float Intensity(const Primitive& p, const Hit& hit, const Eigen::Vector3d& dir_world) {
  const double v = 255.0 * p.albedo * std::abs(hit.normal.dot(dir_world));
  return static_cast<float>(std::clamp(v, 0.0, 255.0));
}

// Runs fn(chunk) for every chunk on up to two threads; chunks are split statically.
template <typename Fn>
void ForEachChunk(size_t num_chunks, Fn fn) {
  const unsigned hw = std::max(1u, std::thread::hardware_concurrency());
  const size_t threads = std::min<size_t>({2, hw, num_chunks});
  if (threads <= 1) {
    for (size_t c = 0; c < num_chunks; ++c) fn(c);
    return;
  }
  std::thread worker([&] {
    for (size_t c = 1; c < num_chunks; c += 2) fn(c);
  });
  for (size_t c = 0; c < num_chunks; c += 2) fn(c);
  worker.join();
}

}  // namespace

void MakeScanPattern(const LidarModel& model, int frame_index, std::vector<Beam>* beams) {
  beams->clear();
  const double period_us = 1e6 / model.frame_rate_hz;
  switch (model.kind) {
    case LidarKind::kOt128:
    case LidarKind::kVlp16:
    case LidarKind::kVlp32c:
    case LidarKind::kOs1_64:
      beams->reserve(static_cast<size_t>(model.nominal_points_per_frame));
      MakeSpinningPattern(model, period_us, beams);
      break;
    case LidarKind::kAvia:
      beams->reserve(static_cast<size_t>(model.nominal_points_per_frame));
      MakeAviaPattern(model, frame_index, period_us, beams);
      break;
    case LidarKind::kMid360:
      beams->reserve(static_cast<size_t>(model.nominal_points_per_frame));
      MakeMid360Pattern(model, frame_index, period_us, beams);
      break;
    case LidarKind::kM1:
      beams->reserve(static_cast<size_t>(kM1Zones) * kM1Lines * kM1Samples);
      MakeM1Pattern(model, frame_index, period_us, beams);
      break;
    case LidarKind::kFalcon:
      beams->reserve(static_cast<size_t>(model.nominal_points_per_frame));
      MakeFalconPattern(model, period_us, beams);
      break;
    case LidarKind::kGeneric:  // described only by its clouds: nothing to simulate
      break;
  }
}

LidarSimulator::LidarSimulator(const LidarModel& model, const LidarNoise& noise)
    : model_(model), noise_(noise) {
  PrepareOpenCvNormals();  // before Scan's threads draw
}

void LidarSimulator::RebuildPatternIfNeeded(int frame_index) {
  // Non-repetitive patterns differ every frame; the M1's raster cycles through 16 phases.
  int key = 0;
  if (model_.kind == LidarKind::kM1) key = M1PhaseKey(frame_index);
  if (model_.kind == LidarKind::kAvia || model_.kind == LidarKind::kMid360)
    key = std::max(frame_index, 0);
  if (key == pattern_key_) return;
  MakeScanPattern(model_, frame_index, &beams_);
  nominal_dir_.resize(beams_.size() * 3);
  fired_dir_.resize(beams_.size() * 3);
  const std::vector<double>& errors = noise_.ring_elevation_error_deg;
  for (size_t i = 0; i < beams_.size(); ++i) {
    const double az = beams_[i].azimuth_rad, el = beams_[i].elevation_rad;
    const int ring = beams_[i].ring;
    const double fired =
        el + (ring >= 0 && ring < static_cast<int>(errors.size()) ? errors[ring] * kDeg2Rad : 0.0);
    for (const auto& [dir, e] : {std::pair{&nominal_dir_, el}, std::pair{&fired_dir_, fired}}) {
      (*dir)[3 * i + 0] = static_cast<float>(std::cos(e) * std::cos(az));
      (*dir)[3 * i + 1] = static_cast<float>(std::cos(e) * std::sin(az));
      (*dir)[3 * i + 2] = static_cast<float>(std::sin(e));
    }
  }
  state_.resize(beams_.size());
  out_.resize(beams_.size());
  pattern_key_ = key;
}

// Pass 1: the main ray of each beam, from the pose at its firing time along its jittered
// direction. Dropped beams are cast too, so their neighbours still see the geometry.
size_t LidarSimulator::SliceOf(size_t i) const {
  if (slices_.size() == 1) return 0;
  const double period_us = 1e6 / model_.frame_rate_hz;
  const auto n = static_cast<int64_t>(slices_.size());
  const int64_t k = static_cast<int64_t>(std::floor(static_cast<double>(beams_[i].time_offset_us) /
                                                    period_us * static_cast<double>(n)));
  return static_cast<size_t>(std::clamp<int64_t>(k, 0, n - 1));
}

void LidarSimulator::CastMainRays(const Pose& T_world_lidar_start, const Pose& T_world_lidar_end,
                                  uint64_t seed, size_t chunk) {
  ChunkRng rng(seed, chunk, 0);
  PoseAt pose(T_world_lidar_start, T_world_lidar_end, 1e6 / model_.frame_rate_hz);
  const double jitter_rad = noise_.angular_jitter_deg * kDeg2Rad;
  const size_t begin = chunk * kChunkBeams, end = std::min(beams_.size(), begin + kChunkBeams);
  Eigen::Vector3d origin, e_az, e_el;
  Eigen::Matrix3d R;
  for (size_t i = begin; i < end; ++i) {
    BeamState& st = state_[i];
    st.dropped = rng.Uniform() < noise_.dropout_probability;
    Eigen::Vector3d d(fired_dir_[3 * i], fired_dir_[3 * i + 1], fired_dir_[3 * i + 2]);
    if (jitter_rad > 0.0) {
      TangentBasis(d, &e_az, &e_el);
      const double a = rng.Normal(), b = rng.Normal();
      d = (d + jitter_rad * (a * e_az + b * e_el)).normalized();
    }
    for (int k = 0; k < 3; ++k) st.dir[k] = static_cast<float>(d[k]);
    pose.Get(beams_[i].time_offset_us, &origin, &R);
    const Eigen::Vector3d d_world = R * d;
    const size_t slice = SliceOf(i);
    const Scene& scene = *slices_[slice];
    Hit hit;
    if (scene.Cast(origin, d_world, model_.min_range_m, model_.max_range_m, sectors_[slice],
                   &hit)) {
      st.t = static_cast<float>(hit.t);
      st.primitive = hit.primitive;
      st.intensity = Intensity(scene.primitives[hit.primitive], hit, d_world);
    } else {
      st.t = -1.0f;
      st.primitive = -1;
      st.intensity = 0.0f;
    }
  }
}

// Pass 2: beams next to a depth edge cast sub-rays over their footprint; then range noise,
// quantization and the point in the LiDAR frame at firing time.
void LidarSimulator::FinishBeams(const Pose& T_world_lidar_start, const Pose& T_world_lidar_end,
                                 const PatternShape& shape, uint64_t seed, size_t chunk) {
  ChunkRng rng(seed, chunk, 1);
  PoseAt pose(T_world_lidar_start, T_world_lidar_end, 1e6 / model_.frame_rate_hz);
  const double footprint_rad = 0.5e-3 * noise_.beam_divergence_mrad;  // half-angle
  const double gap = noise_.mixed_point_min_gap_m;
  const int n = static_cast<int>(beams_.size());
  const size_t begin = chunk * kChunkBeams, end = std::min(beams_.size(), begin + kChunkBeams);
  Eigen::Vector3d origin, e_az, e_el;
  Eigen::Matrix3d R;
  for (size_t i = begin; i < end; ++i) {
    const BeamState& st = state_[i];
    BeamOut& o = out_[i];
    o.valid = false;
    if (st.dropped) continue;
    const size_t slice = SliceOf(i);
    const Scene& scene = *slices_[slice];

    // Only silhouettes matter: a footprint can straddle two depths only where the neighbour
    // hit another primitive far behind or in front, or nothing (primitives are convex, the
    // ground is a plane, so a single primitive never hides part of itself).
    bool edge = false;
    if (footprint_rad > 0.0) {
      int nb[4];
      const int c = PatternNeighbours(shape, static_cast<int>(i), n, nb);
      for (int k = 0; k < c && !edge; ++k) {
        const BeamState& sn = state_[nb[k]];
        if ((st.primitive < 0) != (sn.primitive < 0))
          edge = true;
        else if (st.primitive >= 0 && st.primitive != sn.primitive && std::abs(st.t - sn.t) > gap)
          edge = true;
      }
    }

    double range = st.t;
    float intensity = st.intensity;
    int primitive = st.primitive;
    if (edge) {
      // Footprint: the main ray and four rays on its rim (paper-free model of a beam of
      // divergence beam_divergence_mrad); each hit is one share of the returned energy.
      const Eigen::Vector3d d(st.dir[0], st.dir[1], st.dir[2]);
      TangentBasis(d, &e_az, &e_el);
      pose.Get(beams_[i].time_offset_us, &origin, &R);
      double t[5];
      float inten[5];
      int prim[5];
      int hits = 0;
      if (st.primitive >= 0) {
        t[hits] = st.t;
        inten[hits] = st.intensity;
        prim[hits++] = st.primitive;
      }
      const Eigen::Vector3d offsets[4] = {footprint_rad * e_az, -footprint_rad * e_az,
                                          footprint_rad * e_el, -footprint_rad * e_el};
      for (const Eigen::Vector3d& off : offsets) {
        const Eigen::Vector3d d_world = R * (d + off).normalized();
        Hit hit;
        if (!scene.Cast(origin, d_world, model_.min_range_m, model_.max_range_m, sectors_[slice],
                        &hit))
          continue;
        t[hits] = hit.t;
        inten[hits] = Intensity(scene.primitives[hit.primitive], hit, d_world);
        prim[hits++] = hit.primitive;
      }
      if (hits == 0) continue;
      int nearest = 0;
      double far = t[0];
      for (int k = 1; k < hits; ++k) {
        if (t[k] < t[nearest]) nearest = k;
        far = std::max(far, t[k]);
      }
      const double near = t[nearest];
      if (far - near > gap && noise_.mixed_point_probability > 0.0 &&
          rng.Uniform() < noise_.mixed_point_probability) {
        // Mixed ("ghost") return: the range the sensor's pulse detector reports when the pulse
        // comes back from two depths, between them in proportion to the energy from each.
        const double mid = 0.5 * (near + far);
        int n_far = 0;
        float sum_intensity = 0.0f;
        for (int k = 0; k < hits; ++k) {
          if (t[k] > mid) ++n_far;
          sum_intensity += inten[k];
        }
        range = near + (far - near) * n_far / hits;
        intensity = sum_intensity / static_cast<float>(hits);
        primitive = -1;
      } else if (far - near > gap || st.primitive < 0) {
        range = near;
        intensity = inten[nearest];
        primitive = prim[nearest];
      }
    } else if (st.primitive < 0) {
      continue;
    }

    if (noise_.range_sigma_m > 0.0) range += noise_.range_sigma_m * rng.Normal();
    range += noise_.range_bias_m;
    if (model_.range_quantization_m > 0.0)
      range = std::round(range / model_.range_quantization_m) * model_.range_quantization_m;
    if (range <= 0.0) continue;
    // The sensor reports its nominal (encoder/mirror) direction; the jitter moved the true beam.
    o.x = static_cast<float>(range * nominal_dir_[3 * i]);
    o.y = static_cast<float>(range * nominal_dir_[3 * i + 1]);
    o.z = static_cast<float>(range * nominal_dir_[3 * i + 2]);
    o.intensity = intensity;
    o.board = static_cast<int16_t>(primitive >= 0 ? scene.primitives[primitive].board_index : -1);
    o.valid = true;
  }
}

void LidarSimulator::Scan(const Scene& scene, const Pose& T_world_lidar_start,
                          const Pose& T_world_lidar_end, int frame_index, uint64_t seed,
                          LidarScan* out) {
  Scan(std::vector<const Scene*>{&scene}, T_world_lidar_start, T_world_lidar_end, frame_index, seed,
       out);
}

void LidarSimulator::Scan(const std::vector<const Scene*>& slices, const Pose& T_world_lidar_start,
                          const Pose& T_world_lidar_end, int frame_index, uint64_t seed,
                          LidarScan* out) {
  slices_ = slices;
  RebuildPatternIfNeeded(frame_index);
  // The sensor's path over the beams' firing times (PoseAt: the translation is lerped), for
  // culling each slice's primitives by azimuth.
  int t_first = 0, t_last = 0;
  for (size_t i = 0; i < beams_.size(); ++i) {
    t_first = i == 0 ? beams_[i].time_offset_us : std::min(t_first, beams_[i].time_offset_us);
    t_last = i == 0 ? beams_[i].time_offset_us : std::max(t_last, beams_[i].time_offset_us);
  }
  const double period_us = 1e6 / model_.frame_rate_hz;
  const Eigen::Vector3d p0 = T_world_lidar_start.translation();
  const Eigen::Vector3d step = T_world_lidar_end.translation() - p0;
  sectors_.resize(slices_.size());
  for (size_t k = 0; k < slices_.size(); ++k)
    sectors_[k].Build(*slices_[k], p0 + (t_first / period_us) * step,
                      p0 + (t_last / period_us) * step);
  out->Clear();
  out->Reserve(beams_.size());
  const size_t num_chunks = (beams_.size() + kChunkBeams - 1) / kChunkBeams;
  ForEachChunk(num_chunks,
               [&](size_t c) { CastMainRays(T_world_lidar_start, T_world_lidar_end, seed, c); });
  const PatternShape shape = ShapeOf(model_);
  ForEachChunk(num_chunks, [&](size_t c) {
    FinishBeams(T_world_lidar_start, T_world_lidar_end, shape, seed, c);
  });
  for (size_t i = 0; i < beams_.size(); ++i) {
    const BeamOut& o = out_[i];
    if (!o.valid) continue;
    out->x.push_back(o.x);
    out->y.push_back(o.y);
    out->z.push_back(o.z);
    out->intensity.push_back(o.intensity);
    out->ring.push_back(beams_[i].ring);
    out->time_offset_us.push_back(beams_[i].time_offset_us);
    out->board.push_back(o.board);
  }
  slices_.clear();
}

}  // namespace calibd::sim
