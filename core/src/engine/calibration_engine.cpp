#include "calibd/core/engine/calibration_engine.hpp"

#include <cmath>
#include <functional>
#include <string>
#include <vector>

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/text_format.hpp"
#include "calibd/core/session/capture_order.hpp"
#include "calibd/core/verdict/measure_quality.hpp"
#include "engine/engine_steps.hpp"

namespace calibd {

const char* VerdictName(CalibrationOutcome::Verdict v) {
  switch (v) {
    case CalibrationOutcome::Verdict::kVerified:
      return "verified";
    case CalibrationOutcome::Verdict::kUpdated:
      return "updated";
    case CalibrationOutcome::Verdict::kRejected:
      return "rejected";
  }
  return "rejected";
}

namespace {

CalibrationOutcome Reject(CalibrationOutcome out, Reason reason, const std::string& detail) {
  out.verdict = CalibrationOutcome::Verdict::kRejected;
  out.reason = reason;
  out.detail = detail;
  return out;
}

// The solved extrinsic, its change from the prior and what the board-pose refinement did.
void TakeSolution(const CalibConfig& config, const DirectResult& direct, CalibrationOutcome* out) {
  out->T_camera_lidar = direct.T_camera_lidar;
  out->solved = true;
  out->refined_boards = direct.refined_boards;
  out->board_rotation_change_deg = direct.board_rotation_change_deg;
  out->board_translation_change_m = direct.board_translation_change_m;
  out->delta_rotation_deg =
      RotationAngle(config.prior_T_camera_lidar.linear(), out->T_camera_lidar.linear()) * kRad2Deg;
  out->delta_translation_m =
      (config.prior_T_camera_lidar.translation() - out->T_camera_lidar.translation()).norm();
}

// A session every gate passed: `verified` within the verification tolerance of the prior, else
// `updated`, with what a corrected camera scale asks the user to check.
void Accept(const VerdictConfig& v, CalibrationOutcome* out) {
  const QualityFigures& q = out->quality;
  const bool verified = WithinVerification(v, out->delta_rotation_deg, out->delta_translation_m);
  out->verdict =
      verified ? CalibrationOutcome::Verdict::kVerified : CalibrationOutcome::Verdict::kUpdated;
  out->detail = verified ? "the prior calibration is confirmed"
                         : "the extrinsic changed by " + FixedDecimal(out->delta_rotation_deg) +
                               " deg / " + FixedDecimal(out->delta_translation_m) + " m";
  if (q.camera_scale_corrected != 0.0)
    out->detail += "; the camera's board distances were " +
                   FixedDecimal(std::fabs(q.camera_scale_corrected) * 100.0, 2) + " % " +
                   (q.camera_scale_corrected > 0.0 ? "longer" : "shorter") +
                   " than the LiDAR's and were corrected: measure the printed tag (or "
                   "checkerboard square) and check the camera's focal length";
}

// The pipeline over a session whose frame pairs are in capture order, each once. Each step
// either refuses (the outcome then carries how far it got) or hands on to the next.
CalibrationOutcome CalibrateInCaptureOrder(const CalibConfig& config,
                                           const SessionObservations& observed,
                                           const RangeImage& projection, const EngineConfig& engine,
                                           ObservationSet* correspondences,
                                           std::vector<double>* reprojection_px) {
  if (reprojection_px) reprojection_px->clear();
  CalibrationOutcome out;
  out.prior_T_camera_lidar = out.T_camera_lidar = config.prior_T_camera_lidar;
  QualityFigures& q = out.quality;
  std::string detail;
  auto failed = [](Reason reason) { return reason != Reason::kNone; };
  if (const Reason r = CheckInputs(config, observed, engine, &detail); failed(r))
    return Reject(out, r, detail);

  // 1. Furniture out: clusters that stood still while the boards moved.
  const StaticScenery scenery = FindStaticScenery(observed, config.boards, engine.scenery);
  out.static_scenery_clusters = scenery.num_scenery;
  SessionObservations subset;
  const SessionObservations& session = WithoutStaticScenery(observed, scenery, &subset);
  if (const Reason r = CheckMovingClusters(session, scenery, &detail); failed(r))
    return Reject(out, r, detail);

  // 2. Coarse grid search (paper §III-D): the correspondences and a starting extrinsic.
  ObservationSet local;
  ObservationSet& corr = correspondences ? *correspondences : local;
  corr.Reserve(static_cast<int>(session.camera.size()), static_cast<int>(session.points.size()));
  if (const Reason r = SearchGrid(config, session, projection, engine, &out.grid, &corr, &detail);
      failed(r))
    return Reject(out, r, detail);
  NameClustersInTheSession(observed, scenery, &corr);
  out.T_camera_lidar = out.grid.T_camera_lidar;

  // 3. Motion compensation of the board points to the camera's capture time.
  out.motion = CompensateBoardMotion(session, out.grid.T_camera_lidar, engine.motion, &corr);
  CoverageFigures(config, corr, &q);
  if (const Reason r = CheckCorrespondences(config, engine.verdict, out.motion, corr,
                                            out.grid.T_camera_lidar, q, &detail);
      failed(r))
    return Reject(out, r, detail);

  // 4. Direct optimisation (paper §III-E) with its corrections.
  const CameraModel camera(config.camera);
  const auto t_opt = SteadyClock::now();
  Solution solution;
  if (const Reason r = Solve(config, engine, camera, out.grid.T_camera_lidar, &corr, &q,
                             &out.dropped_correspondences, &solution, &detail);
      failed(r))
    return Reject(out, r, detail);
  out.optimise_ms = MsSince(t_opt);
  out.points_off_their_boards = solution.points_off_their_boards;
  TakeSolution(config, solution.direct, &out);

  // 5. Quality figures, then the verdict's gates (verdict.hpp).
  const auto t_q = SteadyClock::now();
  const StabilityChecks checks{engine.stability_runs, engine.method == EngineConfig::Method::kDirect
                                                          ? engine.start_checks
                                                          : 0};
  // The figures of the solution and the error bound's responses share the threads with its
  // stability re-solves (the longer first); the bound follows from them all.
  Responses responses;
  const std::vector<std::function<void()>> alongside = {
      [&] {
        responses =
            MeasureResponses(config.camera, solution.boards, corr, solution.direct, engine.direct);
      },
      [&] {
        MeasureQuality(config, session, projection, corr, solution.boards, solution.direct, &q);
      }};
  MeasureStabilityAndReprojection(checks, engine.direct, engine.verdict, solution.boards, camera,
                                  corr, solution.direct, alongside, &q, reprojection_px);
  ResponsesAndBound(responses, solution.direct, &q);
  out.quality_ms = MsSince(t_q);
  const GateInput judged{config.camera, engine.verdict, q, out.delta_rotation_deg,
                         out.delta_translation_m};
  if (const Reason r = FailedGate(judged, &detail); failed(r)) return Reject(out, r, detail);
  Accept(engine.verdict, &out);
  return out;
}

}  // namespace

RangeImage SessionProjection(const LidarModel& model) {
  RangeImage projection;
  // Only the grid is used (CellOf, rows): any range limits do, and no point map.
  projection.Configure(model, 0.5, 200.0, 1);
  return projection;
}

CalibrationOutcome Calibrate(const CalibConfig& config, const SessionObservations& observed,
                             const RangeImage& projection, const EngineConfig& engine,
                             ObservationSet* correspondences,
                             std::vector<double>* reprojection_px) {
  int out_of_order = 0, duplicates = 0;
  const std::vector<int> order = CaptureOrder(observed, &out_of_order, &duplicates);
  if (order.empty())
    return CalibrateInCaptureOrder(config, observed, projection, engine, correspondences,
                                   reprojection_px);
  std::vector<int> source_cluster;
  const SessionObservations ordered =
      SelectFrames(observed, order, std::vector<char>(observed.camera.size(), 1),
                   std::vector<char>(observed.lidar.size(), 1), &source_cluster);
  CalibrationOutcome out = CalibrateInCaptureOrder(config, ordered, projection, engine,
                                                   correspondences, reprojection_px);
  out.frames_out_of_order = out_of_order;
  out.duplicate_frames = duplicates;
  if (correspondences)
    for (BoardObservation& o : correspondences->observations) {
      o.frame = order[static_cast<size_t>(o.frame)];
      if (o.lidar_cluster >= 0)
        o.lidar_cluster = source_cluster[static_cast<size_t>(o.lidar_cluster)];
    }
  return out;
}

}  // namespace calibd
