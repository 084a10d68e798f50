#include "calibd/core/verdict/camera_scale.hpp"

#include <algorithm>

#include "calibd/core/session/board_motion.hpp"

namespace calibd {

CameraScaleEstimate EstimateCameraScale(const ObservationSet& set,
                                        const std::vector<BoardDistance>& rows) {
  CameraScaleEstimate est;
  if (static_cast<int>(rows.size()) < kMinScaleBoards) return est;
  // While driving, what is left of the camera's time offset adds tau (n . v) (board_motion.hpp):
  // fitted beside the scale where the boards' velocities are known, or a camera corrected for a
  // large offset would leave part of it to the scale.
  const bool timed = HasTimeOffsetTerm(set, rows);
  const int k = timed ? 5 : 4;
  DistanceFitter scale(k), range(k + 1);
  double near = rows[0].camera_m, far = rows[0].camera_m, distance = 0.0;
  Eigen::VectorXd a(k + 1);
  for (const BoardDistance& b : rows) {
    const Eigen::Vector3d& n = b.normal;
    const BoardObservation& o = *b.observation;
    // Unweighted: near the boards the LiDAR's own scatter, not PnP's, limits a row (weighting by
    // PnP's error, as the time offset does, put a clean still session's scale and range offset
    // at 8 and 4 sigma on the nearest boards).
    a.head<4>() << b.camera_m, n.x(), n.y(), n.z();
    if (timed) a(4) = o.has_velocity ? n.dot(o.velocity) : 0.0;
    const double y = b.camera_m - b.lidar_m;
    scale.Add(o, a.head(k), y);
    a(k) = -n.dot(b.mean_ray);
    range.Add(o, a, y);
    near = std::min(near, b.camera_m);
    far = std::max(far, b.camera_m);
    distance += b.camera_m;
  }
  est.distance_m = distance / static_cast<double>(rows.size());
  const DistanceFit r = range.Fit();
  if (r.fitted) {
    est.range_offset_fitted = true;
    est.range_offset_m = r.x(k);
    est.range_offset_sigma_m = r.Sigma(k, kMinScaleClusterBlocks);
  }
  // A scale shows only over a spread of distances: boards all at one distance leave it to the
  // translation (the fit would be noise). With the range offset beside it where the boards'
  // directions can tell that from a translation: still poses near and far would otherwise take
  // part of a range offset for a scale.
  if (far - near < kMinScaleDistanceSpread * far) return est;
  const DistanceFit& fit = r.fitted ? r : scale.Fit();
  if (fit.fitted) {
    est.scale_fitted = true;
    est.scale = fit.x(0);
    est.scale_sigma = fit.Sigma(0, kMinScaleClusterBlocks);
  }
  return est;
}

void ScaleCameraPatterns(double factor, std::vector<BoardGeometry>* boards, ObservationSet* set) {
  for (BoardGeometry& g : *boards) {
    g.tag_size_m *= factor;
    g.checker_square_size_m *= factor;
  }
  for (BoardObservation& o : set->observations) {
    o.T_camera_board.translation() *= factor;
    o.velocity *= factor;
  }
}

}  // namespace calibd
