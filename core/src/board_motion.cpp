#include "calibd/core/board_motion.hpp"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <map>
#include <vector>

#include "calibd/core/stats.hpp"

namespace calibd {

bool MotionCompensationConfig::IsValid(std::string* error) const {
  auto fail = [&](const char* m) {
    if (error) *error = m;
    return false;
  };
  if (!(window_s > 0.0 && window_s <= 2.0)) return fail("window_s must be in (0, 2] s");
  if (min_samples < 2) return fail("min_samples must be >= 2");
  if (!(min_span_share > 0.0 && min_span_share <= 2.0))
    return fail("min_span_share must be in (0, 2]");
  if (!(max_speed_mps > 0.0)) return fail("max_speed_mps must be > 0");
  return true;
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
  int n = 0;
  double st = 0.0, stt = 0.0, tmin = 1e30, tmax = -1e30;
  Eigen::Vector3d sc = Eigen::Vector3d::Zero(), stc = Eigen::Vector3d::Zero();
  auto take = [&](const SessionObservations::CameraBoard& b) {
    if (b.board_index != board_index) return;
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
  if (n < config.min_samples || tmax - tmin < config.min_span_share * config.window_s) return false;
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
  const Eigen::Matrix3d R_lidar_camera = T_camera_lidar.linear().transpose();
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
    for (int i = o.first_point; i < o.first_point + o.num_points; ++i) {
      const Eigen::Vector3f shift = set->point_dt[i] * u_lidar;
      set->points[i] -= shift;
      stats.max_shift_m = std::max(stats.max_shift_m, static_cast<double>(shift.norm()));
    }
  }
  set->motion_compensated = true;
  return stats;
}

TimeOffsetEstimate EstimateTimeOffset(const ObservationSet& set, const Pose& T_camera_lidar) {
  constexpr int kMinPoints = 10;
  TimeOffsetEstimate est;
  if (!set.motion_compensated) return est;
  struct Row {
    Eigen::Vector4d a;  // n, n . u
    double y;           // d_camera - d_lidar
    int block;
  };
  std::vector<Row> rows;
  rows.reserve(set.observations.size());
  std::vector<double> along;
  std::map<std::pair<int, int>, int> blocks;
  double speed2 = 0.0;
  for (const BoardObservation& o : set.observations) {
    if (o.num_points < kMinPoints) continue;
    const Eigen::Vector3d n = o.T_camera_board.linear().col(2);
    along.clear();
    for (int p = 0; p < o.num_points; ++p)
      along.push_back(n.dot(T_camera_lidar *
                            set.points[static_cast<size_t>(o.first_point + p)].cast<double>()));
    const double nu = o.has_velocity ? n.dot(o.velocity) : 0.0;
    if (o.has_velocity) {
      ++est.observations;
      speed2 += nu * nu;
    }
    const auto key = std::make_pair(o.board_index, o.frame / kTimeOffsetBlockFrames);
    const int block = blocks.emplace(key, static_cast<int>(blocks.size())).first->second;
    // PnP's distance error grows with the distance over the tag's size in the image (d / s_px):
    // each row is weighted by the inverse of that, so that small far tags do not drown the rest.
    double side_px = 0.0;
    for (int c = 0; c < 4; ++c) side_px += (o.corners_px[c] - o.corners_px[(c + 1) % 4]).norm();
    const double d = o.T_camera_board.translation().norm();
    const double w = d > 0.0 && side_px > 0.0 ? side_px / 4.0 / d : 0.0;
    if (!(w > 0.0) || !std::isfinite(w)) continue;
    rows.push_back({w * Eigen::Vector4d(n.x(), n.y(), n.z(), nu),
                    w * (n.dot(o.T_camera_board.translation()) - Quantile(along, 0.5)), block});
  }
  if (est.observations < kMinTimeOffsetObservations) return est;
  est.normal_speed_rms_mps = std::sqrt(speed2 / est.observations);
  const int m = static_cast<int>(rows.size());
  const int g = static_cast<int>(blocks.size());
  if (m <= 4 || g <= 4) return est;
  Eigen::Matrix4d AtA = Eigen::Matrix4d::Zero();
  Eigen::Vector4d Aty = Eigen::Vector4d::Zero();
  for (const Row& r : rows) {
    AtA += r.a * r.a.transpose();
    Aty += r.a * r.y;
  }
  const Eigen::FullPivLU<Eigen::Matrix4d> lu(AtA);
  if (!lu.isInvertible()) return est;
  const Eigen::Vector4d x = lu.solve(Aty);
  const Eigen::Matrix4d inv = lu.inverse();
  // Least squares: inv s^2; cluster-robust (sandwich over the blocks): inv B inv g / (g - 1),
  // B = sum over blocks of (A_b^T e_b)(A_b^T e_b)^T.
  std::vector<Eigen::Vector4d> score(static_cast<size_t>(g), Eigen::Vector4d::Zero());
  double sse = 0.0;
  for (const Row& r : rows) {
    const double e = r.y - r.a.dot(x);
    sse += e * e;
    score[static_cast<size_t>(r.block)] += r.a * e;
  }
  Eigen::Matrix4d B = Eigen::Matrix4d::Zero();
  for (const Eigen::Vector4d& s : score) B += s * s.transpose();
  const double var_ls = inv(3, 3) * sse / (m - 4);
  const double var_cluster = (inv * B * inv)(3, 3) * g / (g - 1);
  const double var = std::max(var_ls, var_cluster);
  if (!std::isfinite(x(3)) || !(var >= 0.0)) return est;
  est.fitted = true;
  est.offset_s = x(3);
  est.sigma_s = std::sqrt(var);
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
