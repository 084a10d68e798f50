#include <algorithm>
#include <cmath>
#include <random>

#include "calibd/core/common/parallel_for.hpp"
#include "calibd/core/verdict/gates/stability_gate.hpp"
#include "calibd/core/verdict/measure_quality.hpp"
#include "calibd/core/verdict/reprojection.hpp"

namespace calibd {

namespace {

// Start `k` of the start checks: the solution turned by kStartCheckRotationDeg and moved by
// kStartCheckTranslationM along fixed directions that differ from check to check.
Pose StartCheckPose(const Pose& T_camera_lidar, int k) {
  static const Eigen::Vector3d kAxes[] = {{1, 1, 0}, {0, -1, 1}, {-1, 0, 1}, {1, -1, -1}};
  const Eigen::Vector3d axis = kAxes[k % 4].normalized();
  Pose start = T_camera_lidar;
  start.linear() =
      RotationFromAxisAngle(axis, kStartCheckRotationDeg / kRad2Deg) * T_camera_lidar.linear();
  start.translation() += kStartCheckTranslationM * Eigen::Vector3d(axis.z(), axis.x(), axis.y());
  return start;
}

// The largest rotation (deg) and translation (m) between `T` and any of `ends`.
void WidestSpread(const std::vector<Pose>& ends, const Pose& T, double* rotation_deg,
                  double* translation_m) {
  for (const Pose& end : ends) {
    *rotation_deg = std::max(*rotation_deg, RotationAngle(end.linear(), T.linear()) * kRad2Deg);
    *translation_m = std::max(*translation_m, (end.translation() - T.translation()).norm());
  }
}

}  // namespace

void MeasureStabilityAndReprojection(const StabilityChecks& checks,
                                     const DirectOptimizerConfig& solver,
                                     const ReprojectionGateConfig& gate,
                                     const std::vector<BoardGeometry>& boards,
                                     const CameraModel& camera, const ObservationSet& corr,
                                     const DirectResult& direct,
                                     const std::vector<std::function<void()>>& alongside,
                                     QualityFigures* q, std::vector<double>* reprojection_px) {
  const Pose& T = direct.T_camera_lidar;
  const int runs = std::max(0, checks.half_data_runs);
  const int starts = std::max(0, checks.start_checks);
  std::mt19937_64 rng(12345);
  std::vector<std::vector<char>> use(runs, std::vector<char>(corr.observations.size()));
  for (auto& u : use)
    for (auto& b : u) b = static_cast<char>(rng() & 1u);
  std::vector<DirectResult> half(static_cast<size_t>(runs)), started(static_cast<size_t>(starts));
  const DirectOptimizerConfig one = ReSolveSettings(solver);
  const int threads = std::max(1, solver.threads);
  const size_t n = corr.observations.size();
  const int chunks = 4 * threads;
  std::vector<double> errors_px(4 * n);
  // Longest first, so that the workers finish together: tasks [0, starts): solves of every board
  // from other starts, board poses refined again from the camera's (does the solve end in the
  // same minimum?); tasks [starts, first_half): `alongside`, one each; tasks
  // [first_half, first_half + runs): re-solves on random halves (deterministic seed) from the full
  // solution with its board poses held, i.e. how far the extrinsic moves when half the boards are
  // left out; then `chunks` tasks: reprojection errors of a slice of the observations each.
  const int first_half = starts + static_cast<int>(alongside.size());
  const int first_chunk = first_half + runs;
  ParallelFor(threads, first_chunk + chunks, [&](int, int task) {
    if (task < starts) {
      started[static_cast<size_t>(task)] =
          OptimizeDirect(boards, corr, StartCheckPose(T, task), one,
                         DirectSolveOptions::RefiningBoardPoses(camera));
    } else if (task < first_half) {
      if (const auto& f = alongside[static_cast<size_t>(task - starts)]) f();
    } else if (task < first_chunk) {
      const int k = task - first_half;
      half[k] = ResolveWithHeldBoards(boards, corr, T, one, direct.T_camera_board, &use[k]);
    } else {
      const size_t c = static_cast<size_t>(task - first_chunk);
      ReprojectionErrors(boards, camera, corr, T, solver, direct.T_camera_board, n * c / chunks,
                         n * (c + 1) / chunks, errors_px.data());
    }
  });
  if (reprojection_px) MeanCornerErrors(errors_px, reprojection_px);
  ReprojectionFigures(std::move(errors_px), q);
  q->reprojection_gate_px =
      ReprojectionGatePx(gate, ReprojectionFocalPx(camera.intrinsics()), q->lidar_spacing_px);
  std::vector<Pose> ends;
  for (const DirectResult& h : half)
    if (h.usable) ends.push_back(h.T_camera_lidar);
  WidestSpread(ends, T, &q->rotation_spread_deg, &q->translation_spread_m);
  ends.clear();
  // A solve that did not converge from there ended nowhere near: as far as its start.
  for (size_t k = 0; k < started.size(); ++k)
    ends.push_back(started[k].usable ? started[k].T_camera_lidar
                                     : StartCheckPose(T, static_cast<int>(k)));
  WidestSpread(ends, T, &q->start_rotation_deg, &q->start_translation_m);
}

}  // namespace calibd
