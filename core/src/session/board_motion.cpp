#include "calibd/core/session/board_motion.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <vector>

#include "calibd/core/common/stats.hpp"
#include "calibd/core/common/validation.hpp"
#include "calibd/core/session/board_distances.hpp"

namespace calibd {

bool MotionCompensationConfig::IsValid(std::string* error) const {
  if (!(window_s > 0.0 && window_s <= kMaxMotionWindowS))
    return Invalid(error, "window_s must be in (0, 2] s");
  if (min_samples < 2) return Invalid(error, "min_samples must be >= 2");
  if (!(min_span_share > 0.0 && min_span_share <= 2.0))
    return Invalid(error, "min_span_share must be in (0, 2]");
  if (!FiniteAbove(max_speed_mps, 0.0)) return Invalid(error, "max_speed_mps must be > 0");
  if (!FiniteAtLeast(max_unmeasured_shift_m, 0.0))
    return Invalid(error, "max_unmeasured_shift_m must be >= 0");
  return true;
}

double MedianFrameInterval(const SessionObservations& s) {
  std::vector<double> intervals_s;
  intervals_s.reserve(s.frame_times.size());
  for (size_t k = 1; k < s.frame_times.size(); ++k) {
    const int64_t d = s.frame_times[k].camera_utime - s.frame_times[k - 1].camera_utime;
    if (d > 0) intervals_s.push_back(static_cast<double>(d) * 1e-6);
  }
  return Median(intervals_s);  // 0 when the times are unknown
}

bool EstimateBoardVelocity(const SessionObservations& s, int frame, int board_index,
                           const MotionCompensationConfig& config, Eigen::Vector3d* velocity) {
  if (frame < 0 || frame >= static_cast<int>(s.frame_times.size())) return false;
  const int64_t t0 = s.frame_times[frame].camera_utime;
  const auto window_us = static_cast<int64_t>(config.window_s * 1e6);
  // Camera boards are stored in frame order: scan outwards from the frame's first entry.
  const auto mid = std::lower_bound(
      s.camera.begin(), s.camera.end(), frame,
      [](const SessionObservations::CameraBoard& b, int f) { return b.frame < f; });
  // Sums for the least-squares line through (t_i, c_i): slope = Sxy / Sxx after centring.
  int n = 0, own = 0;
  double st = 0.0, stt = 0.0, tmin = 0.0, tmax = 0.0;  // the span includes the frame's own time
  Eigen::Vector3d sc = Eigen::Vector3d::Zero(), stc = Eigen::Vector3d::Zero();
  auto take = [&](const SessionObservations::CameraBoard& b) {
    if (b.board_index != board_index) return;
    if (b.frame == frame) {
      own = 1;
      return;
    }
    const double t = static_cast<double>(s.frame_times[b.frame].camera_utime - t0) * 1e-6;
    const Eigen::Vector3d c = b.T_camera_board.translation();
    ++n;
    st += t;
    stt += t * t;
    sc += c;
    stc += t * c;
    tmin = std::min(tmin, t);
    tmax = std::max(tmax, t);
  };
  auto in_window = [&](const SessionObservations::CameraBoard& b) {
    return b.frame >= 0 && b.frame < static_cast<int>(s.frame_times.size()) &&
           std::llabs(s.frame_times[b.frame].camera_utime - t0) <= window_us;
  };
  for (auto it = mid; it != s.camera.end() && in_window(*it); ++it) take(*it);
  for (auto it = mid; it != s.camera.begin() && in_window(*(it - 1)); --it) take(*(it - 1));
  if (n < 2 || n + own < config.min_samples ||
      tmax - tmin < config.min_span_share * config.window_s)
    return false;
  const double sxx = stt - st * st / n;
  if (!(sxx > 0.0)) return false;
  const Eigen::Vector3d u = (stc - st * sc / n) / sxx;
  if (!u.allFinite() || u.norm() > config.max_speed_mps) return false;
  *velocity = u;
  return true;
}

MotionCompensationStats CompensateBoardMotion(const SessionObservations& session,
                                              const Pose& T_camera_lidar,
                                              const MotionCompensationConfig& config,
                                              ObservationSet* set) {
  MotionCompensationStats stats;
  if (!config.enabled || set->motion_compensated || set->point_dt.size() != set->points.size())
    return stats;
  stats.window_s = config.window_s;
  stats.frame_interval_s = MedianFrameInterval(session);
  const Eigen::Matrix3d R_lidar_camera = T_camera_lidar.linear().transpose();
  std::vector<double> shifts;  // per compensated observation: |u| times the points' mean |dt|
  shifts.reserve(set->observations.size());
  for (BoardObservation& o : set->observations) {
    Eigen::Vector3d u;
    o.has_velocity = EstimateBoardVelocity(session, o.frame, o.board_index, config, &u);
    if (!o.has_velocity) {
      ++stats.uncompensated;
      continue;
    }
    o.velocity = u;
    ++stats.compensated;
    // Paper Eq. 5 compares a point with the board where the camera saw it: the board moved by
    // u dt between the capture and the firing, so the point is moved back by as much.
    const Eigen::Vector3f u_lidar = (R_lidar_camera * u).cast<float>();
    double sum_dt = 0.0;
    for (int i = o.first_point; i < o.first_point + o.num_points; ++i) {
      const Eigen::Vector3f shift = set->point_dt[i] * u_lidar;
      set->points[i] -= shift;
      stats.max_shift_m = std::max(stats.max_shift_m, static_cast<double>(shift.norm()));
      sum_dt += std::fabs(set->point_dt[i]);
    }
    shifts.push_back(o.num_points > 0 ? u.norm() * sum_dt / o.num_points : 0.0);
  }
  set->motion_compensated = true;
  stats.median_shift_m = Median(shifts);
  if (stats.uncompensated > 0 && stats.median_shift_m > config.max_unmeasured_shift_m) {
    std::vector<char> measured;
    measured.reserve(set->observations.size());
    for (const BoardObservation& o : set->observations) measured.push_back(o.has_velocity);
    stats.dropped = set->KeepOnly(measured);
  }
  return stats;
}

bool HasTimeOffsetTerm(const ObservationSet& set, const std::vector<BoardDistance>& distances) {
  int moving = 0;
  for (const BoardDistance& b : distances) moving += b.observation->has_velocity;
  return set.motion_compensated && moving >= kMinTimeOffsetObservations;
}

TimeOffsetEstimate EstimateTimeOffset(const ObservationSet& set, const Pose& T_camera_lidar) {
  if (!set.motion_compensated) return TimeOffsetEstimate{};
  return EstimateTimeOffset(set, BoardDistances(set, T_camera_lidar));
}

TimeOffsetEstimate EstimateTimeOffset(const ObservationSet& set,
                                      const std::vector<BoardDistance>& distances) {
  TimeOffsetEstimate est;
  if (!set.motion_compensated) return est;
  DistanceFitter fitter(4);
  double speed2 = 0.0;
  for (const BoardDistance& b : distances) {
    const BoardObservation& o = *b.observation;
    const double nu = o.has_velocity ? b.normal.dot(o.velocity) : 0.0;
    if (o.has_velocity) {
      ++est.observations;
      speed2 += nu * nu;
    }
    fitter.Add(o, b.weight * Eigen::Vector4d(b.normal.x(), b.normal.y(), b.normal.z(), nu),
               b.weight * (b.camera_m - b.lidar_m));
  }
  if (est.observations < kMinTimeOffsetObservations) return est;
  est.normal_speed_rms_mps = std::sqrt(speed2 / est.observations);
  const DistanceFit fit = fitter.Fit();
  if (fit.rows <= 4 || fit.blocks <= 4 || !fit.fitted) return est;
  est.fitted = true;
  est.offset_s = fit.x(3);
  est.sigma_s = fit.Sigma(3, 0);
  return est;
}

void ShiftToCaptureTime(double offset_s, const Pose& T_camera_lidar, ObservationSet* set) {
  if (!set->motion_compensated) return;
  const double step = offset_s - set->time_offset_s;
  const Eigen::Matrix3d R_lidar_camera = T_camera_lidar.linear().transpose();
  for (const BoardObservation& o : set->observations) {
    if (!o.has_velocity) continue;
    const Eigen::Vector3f shift = (step * (R_lidar_camera * o.velocity)).cast<float>();
    for (int i = o.first_point; i < o.first_point + o.num_points; ++i) set->points[i] += shift;
  }
  set->time_offset_s = offset_s;
}

}  // namespace calibd
