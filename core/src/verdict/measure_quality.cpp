#include "calibd/core/verdict/measure_quality.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <limits>
#include <set>

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/session/board_centre_offset.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/session/board_motion.hpp"
#include "calibd/core/verdict/board_flatness.hpp"
#include "calibd/core/verdict/camera_scale.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"
#include "calibd/core/verdict/range_offset.hpp"
#include "calibd/core/verdict/reprojection.hpp"
#include "calibd/core/verdict/ring_elevations.hpp"

namespace calibd {

namespace {

// The worst direction's standard deviation of each block of a covariance in the tangent
// [dt, dtheta]: translation (m) and rotation (deg).
void WorstSigmas(const Eigen::Matrix<double, 6, 6>& cov, double* translation_m,
                 double* rotation_deg) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> et(cov.topLeftCorner<3, 3>());
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> er(cov.bottomRightCorner<3, 3>());
  *translation_m = std::sqrt(std::max(0.0, et.eigenvalues()(2)));
  *rotation_deg = std::sqrt(std::max(0.0, er.eigenvalues()(2))) * kRad2Deg;
}

// The formal covariance, sigma^2 (J^T J)^-1 with sigma the residual RMS, in the tangent
// [dt, dtheta]; false where J^T J is singular.
bool FormalCovariance(const Eigen::Matrix<double, 6, 6>& info, double residual_rms,
                      Eigen::Matrix<double, 6, 6>* cov) {
  const Eigen::FullPivLU<Eigen::Matrix<double, 6, 6>> lu(info);
  if (!lu.isInvertible()) return false;
  *cov = lu.inverse() * (residual_rms * residual_rms);
  return true;
}

// A covariance at least as wide as `a` and as `b` in every direction: `a` plus the positive part
// of b - a (it exceeds b by the negative part's magnitude).
Eigen::Matrix3d CoveringBoth(const Eigen::Matrix3d& a, const Eigen::Matrix3d& b) {
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(b - a);
  return a + es.eigenvectors() * es.eigenvalues().cwiseMax(0.0).asDiagonal() *
                 es.eigenvectors().transpose();
}

void FormalSigmas(const Eigen::Matrix<double, 6, 6>& info, double residual_rms, QualityFigures* q) {
  Eigen::Matrix<double, 6, 6> cov;
  if (!FormalCovariance(info, residual_rms, &cov)) {
    q->rotation_sigma_deg = q->translation_sigma_m = std::numeric_limits<double>::infinity();
    return;
  }
  WorstSigmas(cov, &q->translation_sigma_m, &q->rotation_sigma_deg);  // the worst directions
}

// The camera's scale and the LiDAR's range offset (camera_scale.hpp, range_offset.hpp).
void ScaleAndRangeOffset(const ObservationSet& corr, const std::vector<BoardDistance>& distances,
                         QualityFigures* quality) {
  QualityFigures& q = *quality;
  const CameraScaleEstimate e = EstimateCameraScale(corr, distances);
  if (e.scale_fitted) {
    q.camera_scale_error = (1.0 + q.camera_scale_corrected) * (1.0 + e.scale) - 1.0;
    q.camera_scale_sigma = e.scale_sigma;
    q.camera_scale_translation_m = e.scale_sigma * e.distance_m;
  }
  if (e.range_offset_fitted) {
    q.lidar_range_offset_m = e.range_offset_m;
    q.lidar_range_offset_sigma_m = e.range_offset_sigma_m;
  }
  // The range offset from the plane distances alone where the boards face the LiDAR from varied
  // directions (still poses), or from the boards' in-plane centres too (range_offset.hpp),
  // which determine it while driving towards boards ahead, where the plane distances cannot:
  // whichever is the more precise. Over fewer than kMinScaleClusterBlocks blocks (still poses,
  // a sparse subset of a drive) the centres' sigma is a least-squares one only, which a few
  // poses held by people or beside clutter leave too small (a clean falcon session of 15
  // poses: 2.1 +-0.4 cm, the planes 1.2 +-0.5 cm): there the centres must be twice as precise
  // to be taken. Only here: the corrections use the scale alone.
  if (static_cast<int>(distances.size()) >= kMinScaleBoards) {
    const RangeOffsetFit centres =
        FitRangeOffset(distances, HasTimeOffsetTerm(corr, distances), kMinScaleClusterBlocks);
    const double centres_share = centres.blocks >= kMinScaleClusterBlocks ? 1.0 : 0.5;
    const double planes_sigma_m =
        e.range_offset_fitted ? e.range_offset_sigma_m : std::numeric_limits<double>::infinity();
    if (centres.fitted && centres.sigma_m < centres_share * planes_sigma_m) {
      q.lidar_range_offset_m = centres.offset_m;
      q.lidar_range_offset_sigma_m = centres.sigma_m;
    }
  }
}

// The lasers' elevations against the model's table (ring_elevations.hpp).
void RingElevationFigures(const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                          const RangeImage& projection, const DirectResult& direct,
                          QualityFigures* quality) {
  QualityFigures& q = *quality;
  const Pose& T_camera_lidar = direct.T_camera_lidar;
  const RingElevationCheck rings =
      CheckRingElevations(boards, corr, projection, T_camera_lidar, direct.T_camera_board);
  if (rings.measured) {
    q.ring_elevation_rings = rings.rings;
    q.ring_elevation_rms_deg = rings.rms_deg;
    q.ring_elevation_chi2 = rings.chi2_per_ring;
  }
}

// The most bent board (board_flatness.hpp).
void BoardBendFigures(const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                      const DirectResult& direct, QualityFigures* quality) {
  QualityFigures& q = *quality;
  const Pose& T_camera_lidar = direct.T_camera_lidar;
  for (const BoardBend& b :
       EstimateBoardBends(boards, corr, T_camera_lidar, direct.T_camera_board)) {
    // Where both axes are measured, the one further from flat in its own sigmas.
    for (const auto& [bend, sigma] :
         {std::pair{b.bend_u_m, b.sigma_u_m}, std::pair{b.bend_v_m, b.sigma_v_m}}) {
      if (!std::isfinite(sigma)) continue;
      if (q.board_bend_id < 0 ||
          std::fabs(bend) / sigma > std::fabs(q.board_bend_m) / q.board_bend_sigma_m) {
        q.board_bend_id = boards[static_cast<size_t>(b.board_index)].board_id;
        q.board_bend_m = bend;
        q.board_bend_sigma_m = sigma;
      }
    }
  }
}

// Where the boards' centres lie about their tags, as the camera sees their edges
// (board_centre_offset.hpp): the board furthest off in its sigmas, and what they move the
// translation by.
void BoardCentreFigures(const std::vector<BoardGeometry>& boards, const ObservationSet& corr,
                        QualityFigures* quality) {
  QualityFigures& q = *quality;
  const BoardCentreOffsets offsets =
      EstimateBoardCentreOffsets(corr, static_cast<int>(boards.size()));
  double worst = -1.0;
  for (const BoardCentreOffset& b : offsets.boards) {
    double chi2 = 0.0;
    for (int a = 0; a < 2; ++a)
      if (std::isfinite(b.sigma_m(a)) && b.sigma_m(a) > 0.0)
        chi2 += b.offset_m(a) * b.offset_m(a) / (b.sigma_m(a) * b.sigma_m(a));
    if (chi2 <= worst) continue;
    worst = chi2;
    q.board_centre_offset_id = boards[static_cast<size_t>(b.board_index)].board_id;
    q.board_centre_offset_m = b.offset_m;
    q.board_centre_offset_sigma_m = b.sigma_m;
  }
  q.board_centre_translation_m = offsets.translation_m;
  q.board_centre_translation_cov = offsets.translation_cov;
}

// The principal point the tags fit (principal_point_check.hpp) and the turn it gives the result.
void PrincipalPointFigures(const CalibConfig& config, const SessionObservations& session,
                           QualityFigures* quality) {
  QualityFigures& q = *quality;
  const auto t_pp = SteadyClock::now();
  const PrincipalPointEstimate pp = EstimatePrincipalPoint(config.camera, config.boards, session);
  q.principal_point_fitted = pp.fitted;
  q.principal_point_shift_px = pp.shift_px;
  q.principal_point_sigma_px = pp.sigma_px;
  q.principal_point_systematic_px = pp.systematic_px;
  q.principal_point_residual_px = pp.residual_rms_px;
  q.principal_point_turn_deg = PrincipalPointTurnDeg(pp.shift_px, config.camera);
  q.principal_point_turn_sigma_deg = PrincipalPointTurnDeg(pp.sigma_px, config.camera);
  q.principal_point_stated_sigma_px = config.principal_point_sigma_px;
  q.principal_point_stated_chi2 =
      StatedPrincipalPointChiSquare(pp, config.principal_point_sigma_px, CornerBias::kAssumed);
  for (const CornerBias corners : {CornerBias::kAssumed, CornerBias::kNone}) {
    const PrincipalPointBelief belief =
        CombinePrincipalPoint(pp, config.principal_point_sigma_px, corners);
    QualityFigures::PrincipalPointTurn& turn =
        q.principal_point_beliefs[static_cast<size_t>(corners)];
    turn.turn_deg = PrincipalPointTurnDeg(belief.shift_px, config.camera);
    turn.sigma_rad = {belief.sigma_px.x() / config.camera.fx,
                      belief.sigma_px.y() / config.camera.fy};
    turn.shift_px = belief.shift_px;
    turn.sigma_px = belief.sigma_px;
  }
  q.principal_point_ms = MsSince(t_pp);
}

// What is left of the time offset after the corrections, added to what they applied
// (board_motion.hpp).
void TimeOffsetFigures(const ObservationSet& corr, const std::vector<BoardDistance>& distances,
                       QualityFigures* quality) {
  QualityFigures& q = *quality;
  const TimeOffsetEstimate t = EstimateTimeOffset(corr, distances);
  q.time_offset_fitted = t.fitted;
  q.time_offset_s = corr.time_offset_s + (t.fitted ? t.offset_s : 0.0);
  q.time_offset_sigma_s = t.sigma_s;
  q.time_offset_corrected_s = corr.time_offset_s;
  q.board_normal_speed_mps = t.normal_speed_rms_mps;
}

// VerdictConfig::min_plane_conditioning's figure: smallest / largest eigenvalue of the
// board-plane information, rotations scaled by a 10 m lever arm.
double PlaneConditioning(const DirectResult& direct) {
  Eigen::Matrix<double, 6, 1> scale;
  scale << 1.0, 1.0, 1.0, 10.0, 10.0, 10.0;  // rad -> m at a 10 m lever arm
  const Eigen::Matrix<double, 6, 6> S = scale.cwiseInverse().asDiagonal() *
                                        direct.plane_information *
                                        scale.cwiseInverse().asDiagonal();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(S);
  const double top = es.eigenvalues()(5);
  return top > 0.0 ? std::max(0.0, es.eigenvalues()(0)) / top : 0.0;
}

// The normalised mean of the unit directions from the camera to the boards' centres.
Eigen::Vector3d BoardDirection(const ObservationSet& corr) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const BoardObservation& o : corr.observations)
    sum += o.T_camera_board.translation().normalized();
  return sum.norm() > 0.0 ? Eigen::Vector3d(sum.normalized()) : Eigen::Vector3d::UnitZ();
}

}  // namespace

double FewClustersVarianceFactor(int clusters) {
  // F(3, nu; 0.99) for nu = 1 .. 15 (beyond: chi2(3; 0.99) / 3 = 3.782 at infinity, the last
  // entry a little above it); numerical inversions of the regularised incomplete beta.
  constexpr std::array<double, 15> kF3 = {5403.0, 99.17, 29.46, 16.69, 12.06, 9.780, 8.451, 7.591,
                                          6.992,  6.552, 6.217, 5.953, 5.739, 5.564, 5.417};
  constexpr double kChi2_3 = kBoundNormQuantile3d * kBoundNormQuantile3d;
  if (clusters < 2) return std::numeric_limits<double>::infinity();
  const size_t nu = static_cast<size_t>(std::min(clusters - 1, static_cast<int>(kF3.size())));
  return 3.0 * kF3[nu - 1] / kChi2_3;
}

double GaussianNormQuantile99(const Eigen::Matrix3d& covariance) {
  if (!covariance.allFinite()) return std::numeric_limits<double>::infinity();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> es(covariance);
  const Eigen::Vector3d lambda = es.eigenvalues().cwiseMax(0.0);
  if (!(lambda(2) > 0.0)) return 0.0;
  // e = r u, u uniform on the sphere and r^2 chi-square(3) apart from it: P(|e|^2 <= s) is the
  // sphere's mean of F3(s / u' cov u), F3 the chi-square(3) distribution function; the mean
  // over a Fibonacci lattice of directions, solved for s by bisection between 0 and the worst
  // direction's quantile.
  constexpr int kDirections = 256;
  constexpr double kGolden = 2.39996322972865332;  // rad: pi (3 - sqrt 5)
  std::array<double, kDirections> spread;          // u' diag(lambda) u
  for (int i = 0; i < kDirections; ++i) {
    const double z = 1.0 - (2.0 * i + 1.0) / kDirections;
    const double r = std::sqrt(std::max(0.0, 1.0 - z * z));
    const double x = r * std::cos(kGolden * i), y = r * std::sin(kGolden * i);
    spread[static_cast<size_t>(i)] = lambda(0) * x * x + lambda(1) * y * y + lambda(2) * z * z;
  }
  const auto cdf = [&](double s) {
    double sum = 0.0;
    for (const double g : spread) {
      const double x = s / std::max(g, 1e-300);
      sum += std::erf(std::sqrt(0.5 * x)) - std::sqrt(2.0 * x / M_PI) * std::exp(-0.5 * x);
    }
    return sum / kDirections;
  };
  double lo = 0.0, hi = lambda(2) * kBoundNormQuantile3d * kBoundNormQuantile3d;
  for (int i = 0; i < 60; ++i) {
    const double mid = 0.5 * (lo + hi);
    (cdf(mid) < 0.99 ? lo : hi) = mid;
  }
  return std::sqrt(hi);
}

int ImageCell(double u_px, double v_px, int width, int height) {
  if (!(u_px >= 0.0 && u_px < width && v_px >= 0.0 && v_px < height)) return -1;
  const int col = static_cast<int>(u_px * kImageGridSide / width);
  const int row = static_cast<int>(v_px * kImageGridSide / height);
  return row * kImageGridSide + col;
}

void CoverageFigures(const CalibConfig& config, const ObservationSet& set, QualityFigures* q) {
  const CameraModel camera(config.camera);
  std::set<int> frames, cells;
  q->min_distance_m = 1e9;
  q->max_distance_m = 0.0;
  const double f = 0.5 * (config.camera.fx + config.camera.fy);
  double spacing_sum = 0.0;
  int spaced = 0;
  for (const auto& o : set.observations) {
    frames.insert(o.frame);
    const double d = o.T_camera_board.translation().norm();
    if (o.num_points > 0 && d > 0.0 && o.board_index >= 0 &&
        o.board_index < static_cast<int>(config.boards.size())) {
      const BoardGeometry& b = config.boards[static_cast<size_t>(o.board_index)];
      spacing_sum += f *
                     BoardPointSpacingM(set.points.data() + o.first_point, o.num_points, b.width_m,
                                        b.height_m) /
                     d;
      ++spaced;
    }
    q->min_distance_m = std::min(q->min_distance_m, d);
    q->max_distance_m = std::max(q->max_distance_m, d);
    Eigen::Vector2d uv;
    if (camera.Project(o.T_camera_board.translation(), &uv, 1e6)) {
      // A centre projected just outside the image counts in the nearest border cell.
      const double w = config.camera.width, h = config.camera.height;
      cells.insert(ImageCell(std::clamp(uv.x(), 0.0, std::nextafter(w, 0.0)),
                             std::clamp(uv.y(), 0.0, std::nextafter(h, 0.0)), config.camera.width,
                             config.camera.height));
    }
  }
  if (set.observations.empty()) q->min_distance_m = 0.0;
  q->frames_used = static_cast<int>(frames.size());
  q->boards_used = static_cast<int>(set.observations.size());
  q->lidar_spacing_px = spaced > 0 ? spacing_sum / spaced : 0.0;
  q->image_coverage =
      static_cast<double>(cells.size()) / static_cast<double>(kImageGridSide * kImageGridSide);
}

void MeasureQuality(const CalibConfig& config, const SessionObservations& session,
                    const RangeImage& projection, const ObservationSet& corr,
                    const std::vector<BoardGeometry>& boards, const DirectResult& direct,
                    QualityFigures* q) {
  q->residual_rms_m = direct.residual_rms_m;
  q->information = direct.information;
  q->min_information_eigenvalue = direct.min_information_eigenvalue;
  FormalSigmas(direct.information, direct.residual_rms_m, q);
  const std::vector<BoardDistance> distances = BoardDistances(corr, direct.T_camera_lidar, &boards);
  ScaleAndRangeOffset(corr, distances, q);
  RingElevationFigures(boards, corr, projection, direct, q);
  BoardBendFigures(boards, corr, direct, q);
  BoardCentreFigures(boards, corr, q);
  PrincipalPointFigures(config, session, q);
  TimeOffsetFigures(corr, distances, q);
  q->plane_conditioning = PlaneConditioning(direct);
  q->board_direction = BoardDirection(corr);
}

void ResponsesAndBound(const Responses& responses, const DirectResult& direct, QualityFigures* q) {
  q->principal_point_response_measured = responses.principal_point;
  if (responses.principal_point) q->principal_point_response = responses.per_principal_point_px;
  q->time_offset_response_measured = q->time_offset_fitted && responses.time_offset;
  if (q->time_offset_response_measured) q->time_offset_response = responses.per_time_offset_s;
  q->camera_scale_response_measured = responses.camera_scale;
  if (responses.camera_scale) q->camera_scale_response = responses.per_camera_scale;
  ErrorBound(direct, q);
}

namespace {

// What the principal point, as one reading of the tags believes it, adds to the bound: biases
// (deg, m) and covariances (rad^2, m^2) of the rotation and the translation.
struct PrincipalPointPart {
  double rotation_bias_deg = 0.0, translation_bias_m = 0.0;
  Eigen::Matrix3d rotation_cov = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d translation_cov = Eigen::Matrix3d::Zero();
};

// How the principal point's shift is carried into the result: as the turn d / f (exact while
// every board's pose moves as one rigid turn about the camera), or through the response the
// solve was measured to have (PrincipalPointShiftedBoards: the tags' slant read differently as
// well).
enum class ResponseModel { kTurn, kMeasured };

PrincipalPointPart PrincipalPointBoundPart(const QualityFigures& q,
                                           const QualityFigures::PrincipalPointTurn& pp,
                                           ResponseModel model) {
  PrincipalPointPart part;
  constexpr double kInf = std::numeric_limits<double>::infinity();
  if (!pp.sigma_px.allFinite() || !pp.sigma_rad.allFinite()) {
    part.rotation_cov = part.translation_cov = Eigen::Matrix3d::Constant(kInf);
    return part;
  }
  if (model == ResponseModel::kTurn) {
    // A shift along u turns the camera frame about its y axis, along v about its x axis.
    part.rotation_bias_deg = pp.turn_deg;
    part.rotation_cov = Eigen::Vector3d(pp.sigma_rad.y() * pp.sigma_rad.y(),
                                        pp.sigma_rad.x() * pp.sigma_rad.x(), 0.0)
                            .asDiagonal();
    return part;
  }
  const Eigen::Matrix<double, 6, 2>& R = q.principal_point_response;
  const Eigen::Matrix<double, 6, 1> bias = R * pp.shift_px;
  const Eigen::Matrix<double, 6, 6> cov = R * pp.sigma_px.cwiseAbs2().asDiagonal() * R.transpose();
  part.translation_bias_m = bias.head<3>().norm();
  part.rotation_bias_deg = bias.tail<3>().norm() * kRad2Deg;
  part.translation_cov = cov.topLeftCorner<3, 3>();
  part.rotation_cov = cov.bottomRightCorner<3, 3>();
  return part;
}

// A systematic term carried through a measured response (MeasureResponses): the value left
// after the correction as a bias, its sigma into the covariance, [dt (m), dtheta (rad)].
struct Carried {
  Eigen::Matrix<double, 6, 1> bias = Eigen::Matrix<double, 6, 1>::Zero();
  Eigen::Matrix<double, 6, 6> cov = Eigen::Matrix<double, 6, 6>::Zero();

  double RotationBoundDeg() const {
    return (bias.tail<3>().norm() + GaussianNormQuantile99(cov.bottomRightCorner<3, 3>())) *
           kRad2Deg;
  }
  double TranslationBoundM() const {
    return bias.head<3>().norm() + GaussianNormQuantile99(cov.topLeftCorner<3, 3>());
  }
};

Carried Carry(const Eigen::Matrix<double, 6, 1>& response, double left, double sigma) {
  return {response * left, response * response.transpose() * (sigma * sigma)};
}

}  // namespace

void ErrorBound(const DirectResult& direct, QualityFigures* q) {
  const auto finite = [](double x) { return std::isfinite(x) ? x : 0.0; };
  constexpr double kInf = std::numeric_limits<double>::infinity();
  // What a check estimated and left uncorrected is a bias, added as it is; how uncertain each
  // estimate is joins the statistical part's covariance.
  // The statistical part: the clustered covariance, widened for the few stretches it rests on,
  // and, block by block (translation, rotation), never narrower than the formal one in any
  // direction: boards of tens of points each (a sparse LiDAR's) can leave the clustered one the
  // narrower (docs/error-bound.md). The sigmas reported as clustered are this one's.
  Eigen::Matrix<double, 6, 6> clustered = Eigen::Matrix<double, 6, 6>::Zero();
  if (direct.clustered.valid) {
    clustered = direct.clustered.covariance * FewClustersVarianceFactor(direct.clustered.stretches);
    Eigen::Matrix<double, 6, 6> formal;
    if (FormalCovariance(direct.information, direct.residual_rms_m, &formal)) {
      for (const int k : {0, 3})
        clustered.block<3, 3>(k, k) =
            CoveringBoth(clustered.block<3, 3>(k, k), formal.block<3, 3>(k, k));
    }
    WorstSigmas(clustered, &q->translation_clustered_sigma_m, &q->rotation_clustered_sigma_deg);
    q->rotation_statistical_deg =
        GaussianNormQuantile99(clustered.bottomRightCorner<3, 3>()) * kRad2Deg;
  }
  // The translation's own terms, each along the boards' direction: the range offset (moves it by
  // about itself), and where no response was measured the scale error left after its correction
  // and its sigma (by themselves times the boards' distance), the time offset's sigma (times the
  // boards' speed along their normals).
  struct Term {
    double bias_m = 0.0, sigma_m = 0.0;
  };
  Term range, scale, time;
  if (std::isfinite(q->lidar_range_offset_m))
    range = {std::fabs(q->lidar_range_offset_m), finite(q->lidar_range_offset_sigma_m)};
  // The camera's scale and time offset through their measured responses where there are some:
  // what is left after the correction as a bias, its sigma through the response; both turn the
  // result too. Without a response, each by itself times the boards' distance or normal speed.
  Carried scale_carried, time_carried;
  const bool scale_fitted = std::isfinite(q->camera_scale_error) && q->camera_scale_sigma > 0.0 &&
                            std::isfinite(q->camera_scale_translation_m);
  if (scale_fitted) {
    const double left = (1.0 + q->camera_scale_error) / (1.0 + q->camera_scale_corrected) - 1.0;
    if (q->camera_scale_response_measured) {
      scale_carried = Carry(q->camera_scale_response, left, q->camera_scale_sigma);
    } else {
      const double distance_m = q->camera_scale_translation_m / q->camera_scale_sigma;
      scale = {std::fabs(left) * distance_m, q->camera_scale_translation_m};
    }
  }
  if (q->time_offset_fitted && q->time_offset_response_measured &&
      std::isfinite(q->time_offset_sigma_s)) {
    time_carried = Carry(q->time_offset_response, q->time_offset_s - q->time_offset_corrected_s,
                         q->time_offset_sigma_s);
  } else if (q->time_offset_fitted) {
    time.sigma_m = finite(q->time_offset_sigma_s) * q->board_normal_speed_mps;
  }
  q->rotation_bound_time_offset_deg = time_carried.RotationBoundDeg();
  q->rotation_bound_camera_scale_deg = scale_carried.RotationBoundDeg();
  const double carried_rotation_bias_deg =
      (time_carried.bias.tail<3>().norm() + scale_carried.bias.tail<3>().norm()) * kRad2Deg;
  const Eigen::Matrix<double, 6, 6> carried_cov = time_carried.cov + scale_carried.cov;
  const double k1 = kBoundQuantile1d;
  q->translation_bound_range_offset_m = range.bias_m + k1 * range.sigma_m;
  q->translation_bound_scale_m =
      scale.bias_m + k1 * scale.sigma_m + scale_carried.TranslationBoundM();
  q->translation_bound_time_offset_m =
      time.bias_m + k1 * time.sigma_m + time_carried.TranslationBoundM();
  // The boards' centres about their tags: what the camera sees of them, taken whole into the
  // translation (board_centre_offset.hpp).
  const double board_centre_m = q->board_centre_translation_m.norm();
  q->translation_bound_board_centre_m =
      board_centre_m + GaussianNormQuantile99(q->board_centre_translation_cov);
  const double translation_bias_m = range.bias_m + scale.bias_m + time.bias_m + board_centre_m +
                                    time_carried.bias.head<3>().norm() +
                                    scale_carried.bias.head<3>().norm();
  const double translation_var =
      range.sigma_m * range.sigma_m + scale.sigma_m * scale.sigma_m + time.sigma_m * time.sigma_m;
  const Eigen::Matrix3d translation_cov =
      translation_var * q->board_direction * q->board_direction.transpose() +
      q->board_centre_translation_cov + carried_cov.topLeftCorner<3, 3>();
  // The principal point, which the LiDAR cannot see, as the tags and the intrinsic calibration
  // know it (infinite when neither does: no bound), carried into the result as a turn and
  // through its measured response. Of the two readings of the tags' corners (CornerBias) and the
  // two responses, each bound takes the pair that makes it the larger: it holds whichever is
  // true. Ties keep the first: the blind spot assumed, the turn.
  q->rotation_systematic_deg = q->rotation_bound_deg = q->translation_bound_m = -1.0;
  q->translation_bound_principal_point_m = -1.0;
  for (const auto& [corners, model] : {std::pair{CornerBias::kAssumed, ResponseModel::kTurn},
                                       std::pair{CornerBias::kAssumed, ResponseModel::kMeasured},
                                       std::pair{CornerBias::kNone, ResponseModel::kTurn},
                                       std::pair{CornerBias::kNone, ResponseModel::kMeasured}}) {
    if (model == ResponseModel::kMeasured && !q->principal_point_response_measured) continue;
    const QualityFigures::PrincipalPointTurn& pp =
        q->principal_point_beliefs[static_cast<size_t>(corners)];
    const PrincipalPointPart part = PrincipalPointBoundPart(*q, pp, model);
    const Eigen::Matrix3d systematic_cov =
        part.rotation_cov + carried_cov.bottomRightCorner<3, 3>();
    const double rotation_bias_deg = part.rotation_bias_deg + carried_rotation_bias_deg;
    const double systematic_deg =
        rotation_bias_deg + GaussianNormQuantile99(systematic_cov) * kRad2Deg;
    const double rotation_deg =
        direct.clustered.valid
            ? rotation_bias_deg +
                  GaussianNormQuantile99(clustered.bottomRightCorner<3, 3>() + systematic_cov) *
                      kRad2Deg
            : kInf;
    const double translation_m =
        direct.clustered.valid ? translation_bias_m + part.translation_bias_m +
                                     GaussianNormQuantile99(clustered.topLeftCorner<3, 3>() +
                                                            translation_cov + part.translation_cov)
                               : kInf;
    const double pp_translation_m =
        part.translation_bias_m + GaussianNormQuantile99(part.translation_cov);
    const bool rotation_larger = direct.clustered.valid
                                     ? rotation_deg > q->rotation_bound_deg
                                     : systematic_deg > q->rotation_systematic_deg;
    if (rotation_larger) {
      q->principal_point_bound_corners = corners;
      q->principal_point_belief = pp;
      q->rotation_systematic_deg = systematic_deg;
      q->rotation_bound_deg = rotation_deg;
    }
    const bool translation_larger = direct.clustered.valid
                                        ? translation_m > q->translation_bound_m
                                        : pp_translation_m > q->translation_bound_principal_point_m;
    if (translation_larger) {
      q->translation_bound_m = translation_m;
      q->translation_bound_principal_point_m = pp_translation_m;
    }
  }
  q->translation_systematic_m = translation_bias_m + k1 * std::sqrt(translation_var) +
                                GaussianNormQuantile99(carried_cov.topLeftCorner<3, 3>()) +
                                (q->translation_bound_board_centre_m - board_centre_m) +
                                q->translation_bound_principal_point_m;
}

}  // namespace calibd
