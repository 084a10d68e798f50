#include "calibd/core/lidar/lidar_resolution.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <iomanip>
#include <sstream>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/validation.hpp"
#include "calibd/core/lidar/range_image.hpp"

namespace calibd {

namespace {

constexpr double kMinRangeM = 0.1;
// Angles are quantized to this for sorting (far below any resolution of interest).
constexpr double kQuantumDeg = 0.001;
// Histograms of the angles for the field of view: 0.01 deg bins.
constexpr double kFovBinDeg = 0.01;
constexpr int kAzFovBins = 36000;  // 360 deg
constexpr int kElFovBins = 18000;  // 180 deg

// Histogram of gaps over a log scale: 2% wide bins from 0.005 to 5 deg.
class GapHistogram {
 public:
  static constexpr double kMinDeg = 0.005;
  static constexpr double kRatio = 1.02;
  static constexpr int kBins = 350;  // ceil(ln(1000) / ln(1.02))
  static constexpr int kBridgeBins = 12;

  // Bin of a gap of d quanta, d < bin_of_quanta->size(): from a table (a log per gap would cost
  // a third of the estimate).
  static void MakeTable(size_t max_quanta, std::vector<int16_t>* bin_of_quanta) {
    bin_of_quanta->resize(max_quanta + 1);
    for (size_t d = 0; d <= max_quanta; ++d) {
      const double g = static_cast<double>(d) * kQuantumDeg;
      const double b = d == 0 ? -1.0 : std::floor(std::log(g / kMinDeg) / std::log(kRatio));
      (*bin_of_quanta)[d] = static_cast<int16_t>(b >= 0.0 && b < kBins ? b : -1);
    }
  }
  void Add(int bin) {
    if (bin < 0) return;
    ++counts_[static_cast<size_t>(bin)];
    ++total_;
  }
  int total() const { return total_; }
  // Quantile q of every gap (not only a cluster's), degrees.
  double Quantile(double q) const {
    const double target = q * total_;
    double cum = 0.0;
    for (int i = 0; i < kBins; ++i) {
      cum += counts_[static_cast<size_t>(i)];
      if (cum >= target && counts_[static_cast<size_t>(i)] > 0)
        return kMinDeg * std::pow(kRatio, i + 0.5);
    }
    return kMinDeg * std::pow(kRatio, kBins);
  }

  // Median of the finest cluster holding at least `min_fraction` of the gaps; false when there is
  // none. A cluster is a run of occupied bins in which empty stretches of up to kBridgeBins
  // (a factor 1.27) are bridged: a deterministic pattern's gaps take discrete values (the M1's
  // sinusoidal mirror gives every sample of a line its own gap, 10% apart at the fine end), which
  // are one spread of spacings, not many clusters. `fraction` receives the cluster's share.
  bool FinestCluster(double min_fraction, double* median_deg, double* fraction) const {
    if (total_ == 0) return false;
    // Occupied: the 3-bin sum holds at least 0.2% of the gaps (isolated strays are no cluster).
    const double occupied = std::max(1.0, 0.002 * total_);
    int b = 0;
    while (b < kBins) {
      if (Smoothed(b) < occupied) {
        ++b;
        continue;
      }
      int end = b + 1, last = b;  // [b, end): the cluster; last: its last occupied bin
      while (end < kBins && end - last <= kBridgeBins) {
        if (Smoothed(end) >= occupied) last = end;
        ++end;
      }
      end = last + 1;
      int64_t mass = 0;
      for (int i = b; i < end; ++i) mass += counts_[static_cast<size_t>(i)];
      if (static_cast<double>(mass) >= min_fraction * total_ && mass > 0) {
        // Median inside the cluster, interpolated within its bin on the log scale.
        const double half = 0.5 * static_cast<double>(mass);
        double cum = 0.0;
        for (int i = b; i < end; ++i) {
          const double c = counts_[static_cast<size_t>(i)];
          if (cum + c >= half && c > 0) {
            const double t = (half - cum) / c;
            *median_deg = kMinDeg * std::pow(kRatio, i + t);
            break;
          }
          cum += c;
        }
        *fraction = static_cast<double>(mass) / total_;
        return true;
      }
      b = end;
    }
    return false;
  }

 private:
  int Smoothed(int b) const {
    int s = counts_[static_cast<size_t>(b)];
    if (b > 0) s += counts_[static_cast<size_t>(b - 1)];
    if (b + 1 < kBins) s += counts_[static_cast<size_t>(b + 1)];
    return s;
  }

  std::array<int, kBins> counts_{};
  int total_ = 0;
};

// LSD radix sort of 64-bit keys on 16-bit digits, up to the highest set bit of `max_key`.
void RadixSort(std::vector<uint64_t>* keys, std::vector<uint64_t>* tmp, uint64_t max_key) {
  tmp->resize(keys->size());
  std::vector<uint32_t> count(1u << 16);
  for (int shift = 0; shift < 64 && (max_key >> shift) != 0; shift += 16) {
    std::fill(count.begin(), count.end(), 0u);
    for (const uint64_t k : *keys) ++count[(k >> shift) & 0xffff];
    uint32_t sum = 0;
    for (uint32_t& c : count) {
      const uint32_t n = c;
      c = sum;
      sum += n;
    }
    for (const uint64_t k : *keys) (*tmp)[count[(k >> shift) & 0xffff]++] = k;
    keys->swap(*tmp);
  }
}

// Gaps between consecutive angles along `along` within buckets of `across` of width
// `bucket_deg`: the elevation gaps in azimuth columns, or the azimuth gaps in elevation bands.
// Angles are in [-180, 180] (azimuth) or [-90, 90] (elevation): offset by 180 before quantizing.
void AddGaps(const float* along, const float* across, size_t n, double bucket_deg,
             const LidarResolutionConfig& config, const std::vector<int16_t>& bin_of_quanta,
             std::vector<uint64_t>* keys, std::vector<uint64_t>* tmp, GapHistogram* histogram) {
  keys->resize(n);
  uint64_t max_key = 0;
  for (size_t i = 0; i < n; ++i) {
    const auto bucket = static_cast<uint64_t>(std::floor((across[i] + 180.0) / bucket_deg));
    const auto value = static_cast<uint64_t>(std::llround((along[i] + 180.0) / kQuantumDeg));
    const uint64_t key = (bucket << 20) | value;  // value < 360000 < 2^20
    (*keys)[i] = key;
    max_key = std::max(max_key, key);
  }
  RadixSort(keys, tmp, max_key);
  const auto same_line = static_cast<uint64_t>(std::llround(config.same_line_deg / kQuantumDeg));
  const uint64_t max_gap = bin_of_quanta.size() - 1;
  for (size_t i = 1; i < n; ++i) {
    const uint64_t a = (*keys)[i - 1], b = (*keys)[i];
    if ((a >> 20) != (b >> 20)) continue;  // another bucket
    const uint64_t d = b - a;
    if (d < same_line || d > max_gap) continue;  // one scan line, or a hole
    histogram->Add(bin_of_quanta[d]);
  }
}

// Angle of the quantile `q` of a histogram of `bins` bins of kFovBinDeg from `origin_deg`.
double HistogramQuantile(const std::vector<int>& hist, int64_t total, double q, double origin_deg) {
  const double target = q * static_cast<double>(total);
  double cum = 0.0;
  for (size_t i = 0; i < hist.size(); ++i) {
    cum += hist[i];
    if (cum > target) return origin_deg + (static_cast<double>(i) + 0.5) * kFovBinDeg;
  }
  return origin_deg + static_cast<double>(hist.size()) * kFovBinDeg;
}

// Circular mean of the angles modulo `period` (degrees): the sample phase in [0, period), or
// 0 when the angles show no common phase (resultant shorter than 0.3). Every stride-th angle.
double SamplePhase(const std::vector<float>& angles, double period) {
  const size_t stride = std::max<size_t>(1, angles.size() / 5000);
  double s = 0.0, c = 0.0;
  size_t n = 0;
  for (size_t i = 0; i < angles.size(); i += stride, ++n) {
    const double a = 2.0 * M_PI * angles[i] / period;
    s += std::sin(a);
    c += std::cos(a);
  }
  if (n == 0 || std::hypot(s, c) < 0.3 * static_cast<double>(n)) return 0.0;
  double phase = std::atan2(s, c) / (2.0 * M_PI) * period;
  if (phase < 0.0) phase += period;
  return phase;
}

// Bin edges lie at phase + step / 2 + k * step: the edge at or below `v`, and at or above.
double EdgeBelow(double v, double phase, double step) {
  return phase + 0.5 * step + std::floor((v - phase - 0.5 * step) / step) * step;
}
double EdgeAbove(double v, double phase, double step) {
  return phase + 0.5 * step + std::ceil((v - phase - 0.5 * step) / step) * step;
}

}  // namespace

bool LidarResolutionConfig::IsValid(std::string* error) const {
  if (!(fov_trim_fraction >= 0.0 && fov_trim_fraction < 0.1))
    return Invalid(error, "fov_trim_fraction: must be in [0, 0.1)");
  if (!(full_circle_max_gap_deg > 0.0 && full_circle_max_gap_deg < 180.0))
    return Invalid(error, "full_circle_max_gap_deg: must be in (0, 180)");
  if (!(min_resolution_deg > 0.0 && max_resolution_deg > min_resolution_deg &&
        max_resolution_deg <= 10.0))
    return Invalid(error, "min/max_resolution_deg: need 0 < min < max <= 10");
  if (!(same_line_deg >= kQuantumDeg && same_line_deg < min_resolution_deg))
    return Invalid(error, "same_line_deg: must be in [0.001, min_resolution_deg)");
  if (!(max_gap_deg > max_resolution_deg && max_gap_deg <= 5.0))
    return Invalid(error, "max_gap_deg: must be in (max_resolution_deg, 5]");
  if (!(min_cluster_fraction > 0.0 && min_cluster_fraction <= 1.0))
    return Invalid(error, "min_cluster_fraction: must be in (0, 1]");
  if (!(irregular_gap_spread > 1.0 && irregular_gap_spread < 100.0))
    return Invalid(error, "irregular_gap_spread: must be in (1, 100)");
  if (min_points_per_frame < 10) return Invalid(error, "min_points_per_frame: must be >= 10");
  return true;
}

LidarResolutionEstimate EstimateLidarResolution(const PointCloudView* frames, size_t num_frames,
                                                const LidarResolutionConfig& config) {
  LidarResolutionEstimate est;
  if (!config.IsValid(&est.error)) {
    est.error = "resolution estimator config: " + est.error;
    return est;
  }
  if (frames == nullptr || num_frames == 0) {
    est.error = "no LiDAR frames to estimate the resolution from";
    return est;
  }
  // Angles of every valid point, frame after frame (frame f's points from offsets[f]).
  size_t total = 0;
  for (size_t f = 0; f < num_frames; ++f)
    if (frames[f].x && frames[f].y && frames[f].z) total += frames[f].size;
  std::vector<float> az(total), el(total);
  std::vector<size_t> begin, end;
  size_t n = 0, largest = 0;
  for (size_t f = 0; f < num_frames; ++f) {
    const PointCloudView& c = frames[f];
    if (!c.x || !c.y || !c.z) continue;
    const size_t first = n;
    for (size_t i = 0; i < c.size; ++i) {
      const float x = c.x[i], y = c.y[i], z = c.z[i];
      const float xy = std::sqrt(x * x + y * y);
      const float r = std::sqrt(xy * xy + z * z);
      if (!std::isfinite(r) || !(r >= kMinRangeM)) continue;  // NaN, inf, at the origin
      az[n] = static_cast<float>(FastAtan2(y, x) * kRad2Deg);
      el[n] = static_cast<float>(FastAtan2(z, xy) * kRad2Deg);
      ++n;
    }
    if (static_cast<int>(n - first) < config.min_points_per_frame) {
      n = first;  // too few points: the frame is not used
      continue;
    }
    begin.push_back(first);
    end.push_back(n);
    largest = std::max(largest, n - first);
  }
  az.resize(n);
  el.resize(n);
  est.frames_used = static_cast<int>(begin.size());
  est.points_used = static_cast<int>(n);
  est.max_points_per_frame = static_cast<int>(largest);
  if (begin.empty()) {
    est.error = "no LiDAR frame has " + std::to_string(config.min_points_per_frame) +
                " valid points (finite, farther than 0.1 m): cannot estimate the resolution";
    return est;
  }

  // Field of view from histograms of the angles (robust quantiles in O(n)).
  std::vector<int> az_hist(kAzFovBins, 0), el_hist(kElFovBins, 0);
  std::array<int, 360> az_deg_hist{};
  for (size_t i = 0; i < n; ++i) {
    const int a = std::clamp(static_cast<int>((az[i] + 180.0f) / kFovBinDeg), 0, kAzFovBins - 1);
    const int e = std::clamp(static_cast<int>((el[i] + 90.0f) / kFovBinDeg), 0, kElFovBins - 1);
    ++az_hist[static_cast<size_t>(a)];
    ++el_hist[static_cast<size_t>(e)];
    ++az_deg_hist[static_cast<size_t>(a / 100)];
  }
  const auto total_points = static_cast<int64_t>(n);
  const double trim = config.fov_trim_fraction;
  double el_lo = HistogramQuantile(el_hist, total_points, trim, -90.0);
  double el_hi = HistogramQuantile(el_hist, total_points, 1.0 - trim, -90.0);
  // Largest circular run of (nearly) empty 1-degree azimuth sectors.
  const double empty = std::max(0.0, trim * static_cast<double>(n));
  int best_start = 0, best_len = 0;
  for (int s = 0; s < 360; ++s) {
    if (az_deg_hist[static_cast<size_t>(s)] > empty) continue;
    if (s > 0 && az_deg_hist[static_cast<size_t>(s - 1)] <= empty) continue;  // not a run start
    int len = 0;
    while (len < 360 && az_deg_hist[static_cast<size_t>((s + len) % 360)] <= empty) ++len;
    if (len > best_len) {
      best_len = len;
      best_start = s;
    }
  }
  if (best_len == 0 && az_deg_hist[0] <= empty) best_len = 360;  // nothing occupied (cannot be)
  // The occupied arc is contiguous in [-180, 180] only when the gap contains the +-180 seam.
  const bool gap_has_seam = best_start == 0 || best_start + best_len >= 360;
  est.full_circle = best_len < config.full_circle_max_gap_deg || !gap_has_seam;
  double az_lo = -180.0, az_hi = 180.0;
  if (!est.full_circle) {
    az_lo = HistogramQuantile(az_hist, total_points, trim, -180.0);
    az_hi = HistogramQuantile(az_hist, total_points, 1.0 - trim, -180.0);
  }
  if (!(el_hi - el_lo > 0.05) || !(az_hi - az_lo > 0.05)) {
    est.error = "the points span no field of view (azimuth " + std::to_string(az_hi - az_lo) +
                " deg, elevation " + std::to_string(el_hi - el_lo) +
                " deg): all along one direction?";
    return est;
  }

  // Vertical gaps in azimuth columns two mean sample spacings wide, per frame.
  const double mean_points = static_cast<double>(n) / static_cast<double>(begin.size());
  const double spacing = std::sqrt((az_hi - az_lo) * (el_hi - el_lo) / mean_points);
  est.mean_points_per_frame = static_cast<int>(std::lround(mean_points));
  const double column_deg = std::clamp(2.0 * spacing, 0.05, 5.0);
  std::vector<uint64_t> keys, tmp;
  keys.reserve(largest);
  tmp.reserve(largest);
  std::vector<int16_t> bin_of_quanta;
  GapHistogram::MakeTable(static_cast<size_t>(std::llround(config.max_gap_deg / kQuantumDeg)),
                          &bin_of_quanta);
  GapHistogram vertical;
  for (size_t f = 0; f < begin.size(); ++f)
    AddGaps(el.data() + begin[f], az.data() + begin[f], end[f] - begin[f], column_deg, config,
            bin_of_quanta, &keys, &tmp, &vertical);
  double el_res = 0.0;
  est.vertical_gaps = vertical.total();
  if (!vertical.FinestCluster(config.min_cluster_fraction, &el_res,
                              &est.vertical_cluster_fraction)) {
    est.error = "no vertical spacing between the points (" + std::to_string(vertical.total()) +
                " gaps): not a scanning LiDAR's cloud?";
    return est;
  }
  el_res = std::clamp(el_res, config.min_resolution_deg, config.max_resolution_deg);

  // Horizontal gaps in elevation bands half a vertical step high: one scan line per band.
  const double band_deg = std::max(0.5 * el_res, 0.01);
  GapHistogram horizontal;
  for (size_t f = 0; f < begin.size(); ++f)
    AddGaps(az.data() + begin[f], el.data() + begin[f], end[f] - begin[f], band_deg, config,
            bin_of_quanta, &keys, &tmp, &horizontal);
  double az_res = 0.0;
  est.horizontal_gaps = horizontal.total();
  if (!horizontal.FinestCluster(config.min_cluster_fraction, &az_res,
                                &est.horizontal_cluster_fraction)) {
    est.error = "no horizontal spacing between the points (" + std::to_string(horizontal.total()) +
                " gaps): not a scanning LiDAR's cloud?";
    return est;
  }
  az_res = std::clamp(az_res, config.min_resolution_deg, config.max_resolution_deg);
  // Scan lines or none: along a line the samples are evenly spaced (a spinning sensor's firing
  // step; a MEMS mirror's sinusoid spreads them by up to 2x), so a band's horizontal gaps are
  // nearly equal; a rosette's or a non-repetitive sweep's passes cross a band at random, and
  // their gaps spread like a Poisson process's (quartile ratio ln 4 / ln(4/3) = 4.8). Without
  // lines the finest gap is a petal's own sample step, not a spacing between lines: the bins are
  // the mean spacing instead, square.
  est.horizontal_gap_spread = horizontal.Quantile(0.75) / horizontal.Quantile(0.25);
  est.irregular = est.horizontal_gap_spread > config.irregular_gap_spread;
  if (std::abs(std::log(est.horizontal_gap_spread / config.irregular_gap_spread)) < std::log(1.3)) {
    std::ostringstream o;
    o << std::fixed << std::setprecision(1) << "the pattern is neither clearly in scan lines nor "
      << "clearly irregular (horizontal gaps' quartile ratio " << est.horizontal_gap_spread
      << ", threshold " << config.irregular_gap_spread
      << "): check the bins against the datasheet, or set lidar.generic.azimuth_resolution_deg "
         "and elevation_resolution_deg";
    est.warning = o.str();
  }
  if (est.irregular) {
    el_res = az_res = std::clamp(spacing, config.min_resolution_deg, config.max_resolution_deg);
  }

  // Bins centred on the samples; one step of margin around the trimmed field of view.
  const double el_phase = SamplePhase(el, el_res);
  est.elevation_resolution_deg = el_res;
  est.elevation_min_deg = std::max(-90.0, EdgeBelow(el_lo - el_res, el_phase, el_res));
  est.elevation_max_deg = std::min(90.0, EdgeAbove(el_hi + el_res, el_phase, el_res));
  if (est.full_circle) {
    az_res = 360.0 / std::round(360.0 / az_res);  // whole columns around the circle
    const double az_phase = SamplePhase(az, az_res);
    est.azimuth_min_deg = EdgeBelow(-180.0, az_phase, az_res);
    est.azimuth_max_deg = est.azimuth_min_deg + 360.0;
  } else {
    const double az_phase = SamplePhase(az, az_res);
    est.azimuth_min_deg = EdgeBelow(az_lo - az_res, az_phase, az_res);
    est.azimuth_max_deg = EdgeAbove(az_hi + az_res, az_phase, az_res);
  }
  est.azimuth_resolution_deg = az_res;
  est.ok = true;
  return est;
}

bool GenericLidarConfig::IsValid(std::string* error) const {
  auto fail = [&](const std::string& key, const std::string& m) {
    if (error) *error = "lidar.generic." + key + ": " + m;
    return false;
  };
  for (const auto& [key, v] :
       {std::pair<const char*, double>{"azimuth_resolution_deg", azimuth_resolution_deg},
        {"elevation_resolution_deg", elevation_resolution_deg}})
    if (!(v == 0.0 || (v >= 0.01 && v <= 10.0)))
      return fail(key, "must be 0 (estimate) or in [0.01, 10] deg");
  if (azimuth_fov_set() && !(azimuth_min_deg >= -180.0 && azimuth_max_deg <= 180.0 + 1e-9 &&
                             azimuth_max_deg - azimuth_min_deg >= 1.0))
    return fail("azimuth_min_deg",
                "the azimuth range must lie in [-180, 180] and span at least 1 deg (both 0: "
                "estimate)");
  if (elevation_fov_set() && !(elevation_min_deg >= -90.0 && elevation_max_deg <= 90.0 &&
                               elevation_max_deg - elevation_min_deg >= 1.0))
    return fail("elevation_min_deg",
                "the elevation range must lie in [-90, 90] and span at least 1 deg (both 0: "
                "estimate)");
  if (max_points < 1000 || max_points > 10000000)
    return fail("max_points", "must be in [1000, 10000000]");
  if (!(frame_rate_hz >= 1.0 && frame_rate_hz <= 100.0))
    return fail("frame_rate_hz", "must be in [1, 100]");
  if (estimation_frames < 1 || estimation_frames > 20)
    return fail("estimation_frames", "must be in [1, 20]");
  if (points_per_frame < 0 || points_per_frame > max_points)
    return fail("points_per_frame", "must be 0 (estimate) or in [1, max_points]");
  return true;
}

bool MakeGenericLidarModel(const GenericLidarConfig& config,
                           const LidarResolutionEstimate* estimate, LidarModel* model,
                           std::string* error) {
  if (!config.IsValid(error)) return false;
  const bool have = estimate != nullptr && estimate->ok;
  if (!config.complete() && !have) {
    if (error)
      *error = "generic LiDAR: no estimate of its resolution" +
               (estimate && !estimate->error.empty() ? ": " + estimate->error : std::string()) +
               " (set lidar.generic.* to give it)";
    return false;
  }
  LidarModel m = MakeLidarModel(LidarKind::kGeneric);
  m.azimuth_resolution_deg = config.azimuth_resolution_deg > 0.0 ? config.azimuth_resolution_deg
                                                                 : estimate->azimuth_resolution_deg;
  m.elevation_resolution_deg = config.elevation_resolution_deg > 0.0
                                   ? config.elevation_resolution_deg
                                   : estimate->elevation_resolution_deg;
  if (config.azimuth_fov_set()) {
    m.azimuth_min_deg = config.azimuth_min_deg;
    m.azimuth_max_deg = config.azimuth_max_deg;
  } else {
    m.azimuth_min_deg = estimate->azimuth_min_deg;
    m.azimuth_max_deg = estimate->azimuth_max_deg;
  }
  if (config.elevation_fov_set()) {
    m.elevation_min_deg = config.elevation_min_deg;
    m.elevation_max_deg = config.elevation_max_deg;
  } else {
    m.elevation_min_deg = estimate->elevation_min_deg;
    m.elevation_max_deg = estimate->elevation_max_deg;
  }
  m.frame_rate_hz = config.frame_rate_hz;
  // Buffers are sized from the configured maximum, not from the frames seen so far.
  m.nominal_points_per_frame = config.max_points / 2;
  using Pattern = GenericLidarConfig::Pattern;
  m.non_repetitive = config.pattern == Pattern::kIrregular ||
                     (config.pattern == Pattern::kAuto && have && estimate->irregular);
  if (m.non_repetitive) {
    m.pattern_points_per_frame = config.points_per_frame > 0 ? config.points_per_frame
                                 : have                      ? estimate->mean_points_per_frame
                                                             : 0;
    if (m.pattern_points_per_frame <= 0) {
      if (error)
        *error =
            "generic LiDAR: an irregular pattern needs lidar.generic.points_per_frame (returns "
            "per frame) or frames to estimate it from";
      return false;
    }
  }
  // Bound the range image: 4 cells per point of the largest frame is far beyond any useful
  // binning (one point per cell at the sensor's resolution) and keeps a bad override finite.
  const double cells = (m.azimuth_max_deg - m.azimuth_min_deg) / m.azimuth_resolution_deg *
                       (m.elevation_max_deg - m.elevation_min_deg) / m.elevation_resolution_deg;
  if (!(cells <= 4.0 * config.max_points + 1e5)) {
    if (error) {
      std::ostringstream o;
      o << "generic LiDAR: a range image of " << std::llround(cells)
        << " cells for at most lidar.generic.max_points = " << config.max_points
        << " points: resolution too fine for the field of view";
      *error = o.str();
    }
    return false;
  }
  *model = m;
  return true;
}

bool LidarModelFromConfig(const std::string& name, const GenericLidarConfig& generic,
                          LidarModel* model, std::string* error) {
  LidarKind kind;
  if (!LidarKindFromName(name, &kind, error)) return false;
  if (kind != LidarKind::kGeneric) {
    *model = MakeLidarModel(kind);
    return true;
  }
  if (!generic.complete()) {
    if (error)
      *error =
          "lidar.generic: the agent sizes its buffers at start-up and needs the generic LiDAR's "
          "azimuth_resolution_deg, elevation_resolution_deg, azimuth_min/max_deg and "
          "elevation_min/max_deg (calibd-calibrate on a recording prints and reports the "
          "estimate)";
    return false;
  }
  return MakeGenericLidarModel(generic, nullptr, model, error);
}

std::string DescribeGenericLidar(const LidarModel& model, const LidarResolutionEstimate* estimate) {
  std::ostringstream o;
  o << std::fixed << std::setprecision(3) << "generic LiDAR: azimuth "
    << model.azimuth_resolution_deg << " deg, elevation " << model.elevation_resolution_deg
    << " deg, FOV azimuth [" << std::setprecision(1) << model.azimuth_min_deg << ", "
    << model.azimuth_max_deg << "] deg, elevation [" << model.elevation_min_deg << ", "
    << model.elevation_max_deg << "] deg";
  if (model.non_repetitive)
    o << ", irregular pattern (no scan lines) of about " << model.pattern_points_per_frame
      << " points a frame";
  if (estimate && estimate->ok)
    o << " (estimated from " << estimate->frames_used << " frames, " << estimate->points_used
      << " points; values set in lidar.generic override)";
  else
    o << " (from lidar.generic)";
  if (estimate && estimate->ok && !estimate->warning.empty())
    o << "; warning: " << estimate->warning;
  return o.str();
}

}  // namespace calibd
