#include "calibration_run.hpp"

#include <numeric>

#include "calibd/core/common/stats.hpp"
#include "calibd/drivers/calibration_export.hpp"
#include "quality_json.hpp"

namespace calibd::tools {

namespace {

double Sum(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

}  // namespace

nlohmann::json ReportJson(const CalibrationRun& run, const CalibConfig& config,
                          const std::string& software_version) {
  const CalibrationOutcome& out = run.outcome;
  const LidarModel& lidar_model = run.lidar_model;
  const LogReadStats& stats = run.stats;
  nlohmann::json report;
  report["verdict"] = VerdictName(out.verdict);
  report["reason"] = std::string(NameOf(out.reason));
  report["detail"] = out.detail;
  if (!run.lidar_hint.empty()) report["hint"] = run.lidar_hint;
  if (!run.motion_hint.empty()) report["motion_compensation_hint"] = run.motion_hint;
  report["method"] = run.method;
  report["extract_planes"] = run.read.lidar.extract_planes;
  report["solved"] = out.solved;  // false: T_camera_lidar is only the prior or grid candidate
  report["camera_frame"] = config.camera_frame;
  report["lidar_frame"] = config.lidar_frame;
  report["software_version"] = software_version;
  report["T_camera_lidar"] = TransformJson(out.T_camera_lidar);
  report["T_lidar_camera"] = TransformJson(out.T_camera_lidar.inverse());
  report["prior_T_camera_lidar"] = TransformJson(out.prior_T_camera_lidar);
  report["delta_vs_prior"] = {{"rotation_deg", out.delta_rotation_deg},
                              {"translation_m", out.delta_translation_m}};
  report["quality"] = QualityJson(out.quality);
  report["grid_search"] = {{"perturbation_rpy_deg",
                            {out.grid.perturbation_rpy_deg.x(), out.grid.perturbation_rpy_deg.y(),
                             out.grid.perturbation_rpy_deg.z()}},
                           {"best_count", out.grid.best_count},
                           {"prior_count", out.grid.prior_count},
                           {"total_points", out.grid.total_points},
                           {"candidates", out.grid.candidates}};
  report["motion_compensation"] = {{"compensated_boards", out.motion.compensated},
                                   {"uncompensated_boards", out.motion.uncompensated},
                                   {"dropped_unmeasured_boards", out.motion.dropped},
                                   {"median_shift_m", out.motion.median_shift_m},
                                   {"window_s", out.motion.window_s},
                                   {"frame_interval_s", out.motion.frame_interval_s},
                                   {"max_shift_m", out.motion.max_shift_m}};
  report["lidar_model"] = {
      {"name", lidar_model.name},
      {"azimuth_resolution_deg", lidar_model.azimuth_resolution_deg},
      {"elevation_resolution_deg", lidar_model.elevation_resolution_deg},
      {"azimuth_fov_deg", {lidar_model.azimuth_min_deg, lidar_model.azimuth_max_deg}},
      {"elevation_fov_deg", {lidar_model.elevation_min_deg, lidar_model.elevation_max_deg}},
      {"pattern", lidar_model.non_repetitive ? "irregular" : "lines"}};
  if (lidar_model.non_repetitive)
    report["lidar_model"]["points_per_frame"] = lidar_model.pattern_points_per_frame;
  if (lidar_model.kind == LidarKind::kGeneric) {
    const LidarResolutionEstimate& e = run.lidar_estimate;
    report["lidar_model"]["estimated_from"] = {{"frames", e.frames_used},
                                               {"points", e.points_used},
                                               {"ok", e.ok},
                                               {"error", e.error},
                                               {"warning", e.warning}};
  }
  // LiDAR clusters the engine set aside: standing still while the boards moved (furniture), or
  // paired with a camera board they did not lie on at the solution.
  report["lidar_clusters_dropped"] = {{"static_scenery", out.static_scenery_clusters},
                                      {"not_on_their_board", out.dropped_correspondences}};
  // LiDAR points the engine set aside: beyond their board's outline at the solution (a stand's).
  report["lidar_points_dropped"] = {{"off_their_board", out.points_off_their_boards}};
  report["board_pose_refinement"] = {{"refined_boards", out.refined_boards},
                                     {"mean_rotation_change_deg", out.board_rotation_change_deg},
                                     {"mean_translation_change_m", out.board_translation_change_m}};
  report["frames"] = {{"camera", stats.camera_frames},
                      {"lidar", stats.lidar_frames},
                      {"pairs", stats.pairs},
                      {"pairs_out_of_order", out.frames_out_of_order},
                      {"pairs_repeated", out.duplicate_frames},
                      {"unpaired_camera", stats.unpaired_camera},
                      {"unpaired_lidar", stats.unpaired_lidar},
                      {"bad_messages", stats.bad_messages},
                      {"first_bad_message", stats.first_bad_message},
                      {"nan_points_dropped", stats.nan_points_dropped},
                      {"unmatched_clouds", stats.unmatched_clouds},
                      {"padded_clouds", stats.padded_clouds},
                      {"unmatched_images", stats.unmatched_images},
                      {"over_capacity", stats.frames_over_capacity},
                      {"camera_boards", run.session.camera.size()},
                      {"lidar_boards", run.session.lidar.size()},
                      {"correspondences", run.correspondences.observations.size()}};
  report["timing_ms"] = {{"read_and_detect_total", run.read_s * 1000.0},
                         {"camera_detection_total", Sum(stats.camera_ms)},
                         {"camera_detection_median", Median(stats.camera_ms)},
                         {"lidar_detection_total", Sum(stats.lidar_ms)},
                         {"lidar_detection_median", Median(stats.lidar_ms)},
                         {"grid_search", out.grid.search_ms},
                         {"optimisation", out.optimise_ms},
                         {"quality", out.quality_ms}};
  if (run.truth_rotation_deg >= 0.0)
    report["error_vs_truth"] = {{"rotation_deg", run.truth_rotation_deg},
                                {"translation_m", run.truth_translation_m}};
  return report;
}

}  // namespace calibd::tools
