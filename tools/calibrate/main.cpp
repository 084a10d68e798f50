// calibd-calibrate: calibrates T_camera_lidar offline from a recorded session (LCM log) and a
// calibration config, and writes a JSON report and optional overlay pictures. See --help.

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <iomanip>
#include <iostream>
#include <map>
#include <nlohmann/json.hpp>
#include <numeric>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/core/calibration_engine.hpp"
#include "calibd/core/stats.hpp"
#include "calibd/core/stopwatch.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/drivers/intrinsics_file.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "html_report.hpp"
#include "inspect.hpp"
#include "lidar_model_source.hpp"
#include "log_session.hpp"
#include "overlay.hpp"
#include "quality_json.hpp"

namespace {

using namespace calibd;

constexpr const char* kHelp =
    R"(calibd-calibrate: LiDAR-camera extrinsic calibration of a recorded session.

Usage: calibd-calibrate --log session.lcmlog --config calib.yaml [--report report.json] [options]
       calibd-calibrate --folder DIR --config calib.yaml [--intrinsics FILE] [options]
       calibd-calibrate --inspect --folder DIR [--intrinsics FILE] [--mounting NAME]
                        [--write-config FILE]

Reads the camera and LiDAR frames of the log (calibd's LCM channels) or of a folder of recorded
frames, pairs them by time, detects the configured boards in both sensors, runs the coarse grid
search around the config's prior extrinsic and the direct optimisation (paper Eq. 4-5), and judges
the result against the prior.

--inspect looks at a folder before any config exists: per file, the AprilTags (family, id,
size in px; tag36h11, tag25h9, tagStandard41h12, tag36h10) and checkerboards (inner corners,
square size in px) the image shows, or the cloud's points, rings, elevation span and the named
LiDAR model it fits; then a starter config with those boards, the model and a nominal prior from
--mounting (forward: camera looking forward, LiDAR x forward; backward, left, right), printed or
written to --write-config FILE, with TODO where only a tape measure can tell (board, tag and
square sizes, the lever arm). Unreadable files are named and skipped.

Options:
  --log FILE           LCM log with CALIBD_CAMERA and CALIBD_LIDAR frames
  --folder DIR         instead of --log: a folder of point clouds (*.pcd: ascii, binary or
                       binary_compressed; fields x y z, optional intensity, ring and a point time
                       `time`/`t`/`timestamp`, float seconds or integer nanoseconds) and images
                       (*.png, *.jpg; converted to grey). With DIR/frames.csv the frames pair by
                       time (below); without it a cloud and an image pair by name stem
                       (000123.pcd + 000123.png) and carry no times (pairs are stamped 1 s apart,
                       and motion compensation is off: record such a folder standing still).
                       Unreadable or malformed files are counted (report frames.bad_messages,
                       the first one's error in frames.first_bad_message) and skipped
  --intrinsics FILE    camera intrinsics replacing the config's (whose camera section may then
                       be left out, or hold only id and frame_id): OpenCV FileStorage YAML
                       (camera_matrix or K, distortion_coefficients or D, image_width,
                       image_height), ROS camera_info YAML (camera_matrix.data,
                       distortion_coefficients.data, distortion_model plumb_bob,
                       rational_polynomial with k4-k6 = 0, or equidistant), or JSON
                       {"K": 3x3 or 9 numbers, "D": [...], "width": W, "height": H}
  --config FILE        calibration config: intrinsics, boards, LiDAR model, prior (required).
                       lidar.model ot128, m1, falcon, vlp16, vlp32c, os1-64, avia, mid360 or
                       generic: any LiDAR described only by its
                       points; its resolution and field of view are estimated from the first
                       lidar.generic.estimation_frames (3) LiDAR frames of the log or folder
                       unless lidar.generic.* gives them, printed and written to the report's
                       lidar_model block. An engine section (method, grid, verdict gates:
                       deploy/config/calibd.yaml) is read as calibd-agent reads it; the
                       options below override it; an agent section is the agent's and ignored
  --report FILE        JSON report: verdict, reason, T_camera_lidar and T_lidar_camera (4x4,
                       xyz, quaternion xyzw, rpy), frame names, quality, timings
  --export DIR         the result in other stacks' formats, one file each (DIR is created):
                       calibration.json, T_camera_lidar_opencv.yaml (cv::FileStorage),
                       ros_static_transform_publisher.txt (ROS 1 and ROS 2 commands),
                       T_camera_lidar_tf.yaml (TransformStamped layout),
                       sensor_kit_calibration.yaml (Autoware), calib_velo_to_cam.txt (KITTI);
                       parent frame camera.frame_id, child lidar.frame_id of the config.
                       Written for verified and updated results only (not when rejected)
  --overlay DIR        PNG pictures of LiDAR points projected with the result (4 frames across the
                       distance range), detected corners in green, LiDAR-fitted corners in red
  --html FILE          the result as one self-contained HTML page (no network resources): verdict
                       and reason, T_camera_lidar and its inverse, change vs prior, quality
                       figures against the gates applied, reprojection errors per board and
                       against distance (plots), the overlay pictures, provenance (version,
                       config SHA-256, input, frames used)
  --truth FILE         the simulator's truth JSON: adds the error against ground truth to the
                       report (evaluation only; the calibration never sees it)
  --method NAME        direct (default) or indirect (Huang & Grizzle baseline)
  --motion-compensation on|off
                       move LiDAR board points to the camera's capture time with the boards'
                       apparent velocity (default on; off when the sensors' clocks or the
                       per-point time offsets cannot be trusted)
  --board-pose-refinement on|off
                       refine every board's pose from its tag corners and its LiDAR points
                       together with the extrinsic, instead of taking the camera's PnP pose as
                       exact (default on; off gives the paper's Eq. 4 as published)
  --extract-planes on|off
                       search LiDAR clusters refused as a whole (a board joined to the wall
                       behind it, its tripod, the person holding it) for board planes: finds
                       boards in cluttered indoor still poses, at some cost in time and in
                       board-like furniture (dropped when it stands still while the board
                       moves) (default on; calibd-agent, which runs in real time on streams of
                       boards standing free, leaves it off)
  --debug DIR          what the detectors made of each frame pair, one JSON file per pair
                       (DIR/pair_000000.json, DIR is created): the camera's boards (corners,
                       PnP error, decision margin) and rejected candidates, and every LiDAR
                       cluster with its cells, rectangle, RMS size, planarity, tilt, attached
                       share, descriptor score and the gate that stopped it (board, too_large,
                       attached, on_ground, not_planar, tilted, rectangle, size, descriptor,
                       capacity); and DIR/pair_000000.png, the range image (top: highest
                       elevation) with each cell coloured by that gate: board green, descriptor
                       orange, rectangle or size magenta, not_planar or tilted blue, too_large,
                       attached or capacity red, on_ground brown, ground dark green, the rest grey
  --max-frames N       frame pairs kept (default 2000)
  --pair-tolerance-ms  camera time allowed outside the LiDAR sweep (default 20)
  --quiet              no progress or summary

%CSV%

Exit codes: 0 verified or updated, 3 rejected (reason in the report), 1 failed, 2 bad option.
)";

double Sum(const std::vector<double>& v) { return std::accumulate(v.begin(), v.end(), 0.0); }

// Up to 4 frame pairs spread over the camera-to-board distances of the correspondences.
std::vector<int> OverlayFrames(const ObservationSet& corr) {
  std::map<int, double> dist;
  for (const auto& o : corr.observations) dist[o.frame] = o.T_camera_board.translation().norm();
  std::vector<std::pair<double, int>> by_distance;
  for (const auto& [frame, d] : dist) by_distance.emplace_back(d, frame);
  std::sort(by_distance.begin(), by_distance.end());
  std::vector<int> frames;
  for (int i = 0; i < 4 && !by_distance.empty(); ++i) {
    const size_t k = (by_distance.size() - 1) * static_cast<size_t>(i) / 3;
    if (std::find(frames.begin(), frames.end(), by_distance[k].second) == frames.end())
      frames.push_back(by_distance[k].second);
  }
  return frames;
}

// A hint when the LiDAR gave no board for more than a fifth of the camera boards taking part in
// the solve (the grid search pairs each camera board with a LiDAR board in its predicted region);
// empty otherwise, and for a non-repetitive LiDAR's stream (frames under 0.25 s apart), whose
// sweeps each cover part of a still board: the others find it.
std::string LidarMissHint(const SessionObservations& session, const ObservationSet& corr,
                          int max_solve_frames, const LidarModel& model) {
  std::vector<double> gaps_us;
  for (size_t f = 1; f < session.frame_times.size(); ++f)
    gaps_us.push_back(static_cast<double>(session.frame_times[f].camera_utime -
                                          session.frame_times[f - 1].camera_utime));
  const bool stream = !gaps_us.empty() && Median(gaps_us) < 250000.0;
  if (model.non_repetitive && stream) return "";
  int camera_boards = 0;
  for (const auto& c : session.camera)
    camera_boards += SpreadFrameSelected(c.frame, session.num_frames, max_solve_frames) ? 1 : 0;
  const int missed = camera_boards - static_cast<int>(corr.observations.size());
  if (camera_boards == 0 || 5 * missed <= camera_boards) return "";
  return "the LiDAR gave no board for " + std::to_string(missed) + " of " +
         std::to_string(camera_boards) +
         " camera boards (--debug DIR shows the gate that stopped each cluster); " +
         (model.non_repetitive
              ? "one sweep of a non-repetitive LiDAR covers only part of a board: record about a "
                "second of sweeps per pose (each paired with its image), or clouds integrated "
                "over it"
              : "closer or larger boards put more of the LiDAR's scan lines on each");
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, folder_path, intrinsics_path, config_path, report_path, overlay_dir,
      truth_path, export_dir;
  std::string html_path;  // --html
  std::string method = "direct";
  bool motion_compensation = true;
  bool board_pose_refinement = true;
  // Given on the command line: then over the config's engine section.
  bool method_given = false, motion_compensation_given = false, board_pose_refinement_given = false;
  tools::LogReadOptions read_options;
  // Offline, the time plane extraction costs (tens of ms a frame) buys the boards of cluttered
  // still poses (recordings from other rigs).
  read_options.lidar.extract_planes = true;
  bool quiet = false;
  bool inspect = false;
  tools::InspectOptions inspect_options;
  for (int i = 1; i < argc; ++i) {
    const std::string arg = argv[i];
    if (arg == "--help" || arg == "-h") {
      std::string help = kHelp;
      help.replace(help.find("%CSV%"), 5, kFramesCsvHelp);
      std::cout << help;
      return 0;
    }
    if (arg == "--quiet") {
      quiet = true;
      continue;
    }
    if (arg == "--inspect") {
      inspect = true;
      continue;
    }
    if (i + 1 >= argc) {
      std::cerr << "calibd-calibrate: option " << arg << " needs a value (see --help)\n";
      return 2;
    }
    const std::string value = argv[++i];
    char* end = nullptr;
    if (arg == "--log")
      log_path = value;
    else if (arg == "--folder")
      folder_path = value;
    else if (arg == "--intrinsics")
      intrinsics_path = value;
    else if (arg == "--config")
      config_path = value;
    else if (arg == "--report")
      report_path = value;
    else if (arg == "--overlay")
      overlay_dir = value;
    else if (arg == "--html")
      html_path = value;
    else if (arg == "--export")
      export_dir = value;
    else if (arg == "--debug")
      read_options.debug_dir = value;
    else if (arg == "--truth")
      truth_path = value;
    else if (arg == "--mounting")
      inspect_options.mounting = value;
    else if (arg == "--write-config")
      inspect_options.config_out = value;
    else if (arg == "--method") {
      method = value;
      method_given = true;
    } else if (arg == "--extract-planes") {
      if (value != "on" && value != "off") {
        std::cerr << "calibd-calibrate: " << arg << " must be on or off (got '" << value << "')\n";
        return 2;
      }
      read_options.lidar.extract_planes = value == "on";
    } else if (arg == "--motion-compensation" || arg == "--board-pose-refinement") {
      if (value != "on" && value != "off") {
        std::cerr << "calibd-calibrate: " << arg << " must be on or off (got '" << value << "')\n";
        return 2;
      }
      (arg == "--motion-compensation" ? motion_compensation : board_pose_refinement) =
          value == "on";
      (arg == "--motion-compensation" ? motion_compensation_given : board_pose_refinement_given) =
          true;
    } else if (arg == "--max-frames") {
      const long n = std::strtol(value.c_str(), &end, 10);
      if (*end != '\0' || n < 1 || n > 100000) {
        std::cerr << "calibd-calibrate: --max-frames must be an integer in [1, 100000]\n";
        return 2;
      }
      read_options.max_frames = static_cast<int>(n);
    } else if (arg == "--pair-tolerance-ms") {
      const double ms = std::strtod(value.c_str(), &end);
      if (*end != '\0' || !(ms >= 0.0 && ms <= 1000.0)) {
        std::cerr << "calibd-calibrate: --pair-tolerance-ms must be a number in [0, 1000]\n";
        return 2;
      }
      read_options.pair_tolerance_us = static_cast<int64_t>(ms * 1000.0);
    } else {
      std::cerr << "calibd-calibrate: unknown option '" << arg << "' (see --help)\n";
      return 2;
    }
  }
  if (inspect) {
    if (folder_path.empty() || !log_path.empty() || !config_path.empty()) {
      std::cerr << "calibd-calibrate: --inspect needs --folder DIR and no --log or --config (see "
                   "--help)\n";
      return 2;
    }
    inspect_options.folder = folder_path;
    inspect_options.intrinsics_path = intrinsics_path;
    return tools::RunInspect(inspect_options, std::cout, std::cerr);
  }
  if (log_path.empty() == folder_path.empty() || config_path.empty()) {
    std::cerr << "calibd-calibrate: --config and one of --log or --folder are required (see "
                 "--help)\n";
    return 2;
  }
  if (method != "direct" && method != "indirect") {
    std::cerr << "calibd-calibrate: --method must be direct or indirect (got '" << method << "')\n";
    return 2;
  }

  std::string error;
  // --intrinsics first: with them the config's camera section is optional. The config may hold
  // the agent's sections: `engine:` is read as the agent reads it, `agent:` is the agent's own.
  CameraIntrinsics intrinsics;
  if (!intrinsics_path.empty() && !LoadIntrinsicsFile(intrinsics_path, &intrinsics, &error)) {
    std::cerr << "calibd-calibrate: --intrinsics: " << error << "\n";
    return 2;
  }
  ConfigParseOptions parse_options;
  parse_options.intrinsics = intrinsics_path.empty() ? nullptr : &intrinsics;
  parse_options.other_sections = {"engine", "agent"};
  CalibConfig config;
  EngineConfig engine;
  std::string config_text;
  if (!ReadWholeFile(config_path, &config_text, &error) ||
      !ParseConfigYaml(config_text, &config, &error, parse_options) ||
      !ParseEngineConfigYaml(config_text, &engine, &error)) {
    std::cerr << "calibd-calibrate: " << (config_text.empty() ? "" : config_path + ": ") << error
              << "\n";
    return 2;
  }
  // The log or the folder, read the same way (pairing, detection, counters).
  auto read_session = [&](const tools::LogReadOptions& options, SessionObservations* into,
                          tools::LogReadStats* counters, const std::function<void(int)>& report,
                          const std::vector<int>& keep, std::vector<tools::FramePairData>* kept) {
    return folder_path.empty() ? tools::ReadSessionLog(log_path, config, options, into, counters,
                                                       &error, report, keep, kept)
                               : tools::ReadSessionFolder(folder_path, config, options, into,
                                                          counters, &error, report, keep, kept);
  };
  // The LiDAR model; for generic, estimated from the first frames and shown to the user.
  LidarModel lidar_model;
  LidarResolutionEstimate lidar_estimate;
  if (!tools::LidarModelForSession({log_path, folder_path}, config, &lidar_model, &lidar_estimate,
                                   &error)) {
    std::cerr << "calibd-calibrate: " << error << "\n";
    return 1;
  }
  read_options.lidar_model = lidar_model;
  if (!quiet && lidar_model.kind == LidarKind::kGeneric)
    std::cerr << "calibd-calibrate: " << DescribeGenericLidar(lidar_model, &lidar_estimate) << "\n";
  if (!read_options.debug_dir.empty() && !CreateDirectories(read_options.debug_dir, &error)) {
    std::cerr << "calibd-calibrate: --debug: " << error << "\n";
    return 2;
  }
  const auto t_start = std::chrono::steady_clock::now();
  SessionObservations session;
  tools::LogReadStats stats;
  auto progress = [&](int pairs) {
    if (!quiet) std::cerr << "calibd-calibrate: " << pairs << " frame pairs detected\n";
  };
  if (!read_session(read_options, &session, &stats, progress, {}, nullptr)) {
    std::cerr << "calibd-calibrate: " << error << "\n";
    return 1;
  }
  if (stats.debug_write_failures > 0)
    std::cerr << "calibd-calibrate: warning: " << stats.debug_write_failures
              << " --debug file(s) not written (first: " << stats.first_debug_error << ")\n";
  if (stats.padded_clouds > 0)
    std::cerr << "calibd-calibrate: warning: " << stats.padded_clouds
              << " binary PCD file(s) have bytes after their last point, ignored as PCL ignores "
                 "them (first: "
              << stats.first_padded_cloud << ")\n";
  const double read_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();

  const RangeImage projection = SessionProjection(lidar_model);
  // The command line's choices over the config's engine section.
  if (method_given)
    engine.method =
        method == "indirect" ? EngineConfig::Method::kIndirect : EngineConfig::Method::kDirect;
  if (motion_compensation_given) engine.motion.enabled = motion_compensation;
  // Pairs by name stem carry made-up times: no velocity can be fitted to them, whatever the
  // window.
  if (stats.pseudo_times) engine.motion.enabled = false;
  if (board_pose_refinement_given) engine.direct.refine_board_poses = board_pose_refinement;
  method = engine.method == EngineConfig::Method::kIndirect ? "indirect" : "direct";
  ObservationSet corr;
  std::vector<double> reprojection_px;  // per correspondence, for --html
  CalibrationOutcome out = Calibrate(config, session, projection, engine, &corr, &reprojection_px);
  // Without a single frame pair the input is the cause, not the boards: say what it lacked.
  bool lidar_cause = false;
  const std::string no_pairs =
      tools::NoPairsCause(stats, config, !folder_path.empty(), &lidar_cause);
  if (!no_pairs.empty() && !out.solved) {
    out.reason = lidar_cause ? Reason::kNoLidarBoards : Reason::kNoCameraBoards;
    out.detail = no_pairs;
  }
  const auto& q = out.quality;
  const std::string lidar_hint = LidarMissHint(session, corr, engine.max_solve_frames, lidar_model);
  const std::string motion_hint =
      out.motion.FramesBeyondWindow()
          ? "the frame pairs lie " + FixedDecimal(out.motion.frame_interval_s, 2) +
                " s apart, beyond the +-" + FixedDecimal(out.motion.window_s, 2) +
                " s in which board velocities are fitted, so no board's motion was measured or "
                "compensated: if the boards moved against the car (driving, boards carried), set "
                "engine.motion_window_s to " +
                FixedDecimal(std::min(1.5 * out.motion.frame_interval_s, kMaxMotionWindowS), 2) +
                " in the config"
          : "";
  if (!motion_hint.empty() && !quiet)
    std::cerr << "calibd-calibrate: note: " << motion_hint << "\n";

  nlohmann::json report;
  report["verdict"] = VerdictName(out.verdict);
  report["reason"] = std::string(NameOf(out.reason));
  report["detail"] = out.detail;
  if (!lidar_hint.empty()) report["hint"] = lidar_hint;
  if (!motion_hint.empty()) report["motion_compensation_hint"] = motion_hint;
  report["method"] = method;
  report["extract_planes"] = read_options.lidar.extract_planes;
  report["solved"] = out.solved;  // false: T_camera_lidar is only the prior or grid candidate
  report["camera_frame"] = config.camera_frame;
  report["lidar_frame"] = config.lidar_frame;
  report["software_version"] = std::string("calibd ") + CALIBD_VERSION;
  report["T_camera_lidar"] = TransformJson(out.T_camera_lidar);
  report["T_lidar_camera"] = TransformJson(out.T_camera_lidar.inverse());
  report["prior_T_camera_lidar"] = TransformJson(out.prior_T_camera_lidar);
  report["delta_vs_prior"] = {{"rotation_deg", out.delta_rotation_deg},
                              {"translation_m", out.delta_translation_m}};
  report["quality"] = QualityJson(q);
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
  if (lidar_model.kind == LidarKind::kGeneric)
    report["lidar_model"]["estimated_from"] = {{"frames", lidar_estimate.frames_used},
                                               {"points", lidar_estimate.points_used},
                                               {"ok", lidar_estimate.ok},
                                               {"error", lidar_estimate.error},
                                               {"warning", lidar_estimate.warning}};
  // LiDAR clusters the engine set aside: standing still while the boards moved (furniture), or
  // paired with a camera board they did not lie on at the solution.
  report["lidar_clusters_dropped"] = {{"static_scenery", out.static_scenery_clusters},
                                      {"not_on_their_board", out.dropped_correspondences}};
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
                      {"camera_boards", session.camera.size()},
                      {"lidar_boards", session.lidar.size()},
                      {"correspondences", corr.observations.size()}};
  report["timing_ms"] = {{"read_and_detect_total", read_s * 1000.0},
                         {"camera_detection_total", Sum(stats.camera_ms)},
                         {"camera_detection_median", Median(stats.camera_ms)},
                         {"lidar_detection_total", Sum(stats.lidar_ms)},
                         {"lidar_detection_median", Median(stats.lidar_ms)},
                         {"grid_search", out.grid.search_ms},
                         {"optimisation", out.optimise_ms},
                         {"quality", out.quality_ms}};
  double truth_rot = -1.0, truth_trans = -1.0;
  if (!truth_path.empty()) {
    std::string text;
    if (!ReadWholeFile(truth_path, &text, &error)) {
      std::cerr << "calibd-calibrate: " << error << "\n";
      return 1;
    }
    try {
      const auto truth = nlohmann::json::parse(text);
      Pose T = Pose::Identity();
      for (int r = 0; r < 3; ++r)
        for (int c = 0; c < 4; ++c)
          T.matrix()(r, c) = truth.at("T_camera_lidar").at(r).at(c).get<double>();
      truth_rot = RotationAngle(out.T_camera_lidar.linear(), T.linear()) * kRad2Deg;
      truth_trans = (out.T_camera_lidar.translation() - T.translation()).norm();
      report["error_vs_truth"] = {{"rotation_deg", truth_rot}, {"translation_m", truth_trans}};
    } catch (const std::exception& e) {
      std::cerr << "calibd-calibrate: truth file '" << truth_path << "': " << e.what() << "\n";
      return 1;
    }
  }
  if (!report_path.empty() && !WriteFileAtomic(report_path, report.dump(2) + "\n", &error)) {
    std::cerr << "calibd-calibrate: " << error << "\n";
    return 1;
  }
  // A rejected result is no calibration to hand on: other stacks would load it without a verdict.
  if (!export_dir.empty() && out.verdict != CalibrationOutcome::Verdict::kRejected) {
    CalibrationExport e;
    e.T_camera_lidar = out.T_camera_lidar;
    e.camera_frame = config.camera_frame;
    e.lidar_frame = config.lidar_frame;
    e.software_version = std::string("calibd ") + CALIBD_VERSION;
    e.calibrated_unix_s = static_cast<int64_t>(std::time(nullptr));
    if (!WriteCalibrationExports(export_dir, e, &error)) {
      std::cerr << "calibd-calibrate: " << error << "\n";
      return 1;
    }
  }

  tools::HtmlReportInput html;  // --html: filled with the pictures here, the rest below
  if ((!overlay_dir.empty() || !html_path.empty()) && !corr.observations.empty()) {
    if (!overlay_dir.empty()) std::filesystem::create_directories(overlay_dir);
    const std::vector<int> frames = OverlayFrames(corr);
    std::vector<tools::FramePairData> kept;
    SessionObservations unused;
    tools::LogReadStats pass_stats;
    tools::LogReadOptions pictures_only = read_options;
    pictures_only.detect = false;  // the pairs were detected above; only their data is needed
    if (!read_session(pictures_only, &unused, &pass_stats, {}, frames, &kept)) {
      std::cerr << "calibd-calibrate: " << error << "\n";
      return 1;
    }
    const CameraModel camera(config.camera);
    for (const auto& f : kept) {
      cv::Mat bgr;
      const ImageView view{f.image.data, f.image.cols, f.image.rows,
                           static_cast<int>(f.image.step[0])};
      viz::DrawLidarOverlay(
          view, PointCloudView{f.x.data(), f.y.data(), f.z.data(), nullptr, f.x.size(), nullptr},
          out.T_camera_lidar, camera, 0.5, &bgr);
      std::vector<Eigen::Vector2d> detected, fitted;
      for (const auto& o : corr.observations) {
        if (o.frame != f.pair_index) continue;
        detected.insert(detected.end(), o.corners_px.begin(), o.corners_px.end());
        std::array<Eigen::Vector2d, 4> px;
        if (!FittedTagCornersPx(camera, config.boards, corr, o, out.T_camera_lidar, engine.direct,
                                &px))
          continue;
        for (const auto& p : px)
          if (p.allFinite()) fitted.push_back(p);
      }
      viz::DrawMarkers(detected, 0.5, cv::Scalar(0, 255, 0), &bgr);
      viz::DrawMarkers(fitted, 0.5, cv::Scalar(0, 0, 255), &bgr);
      if (!html_path.empty()) {
        tools::ReportImage image;
        image.caption = "frame pair " + std::to_string(f.pair_index) +
                        ": LiDAR points through the result, detected tag corners in green, "
                        "LiDAR-fitted corners in red";
        cv::imencode(".png", bgr, image.png);
        html.images.push_back(std::move(image));
      }
      if (overlay_dir.empty()) continue;
      const std::string path = overlay_dir + "/pair_" + std::to_string(f.pair_index) + ".png";
      if (!cv::imwrite(path, bgr)) {
        std::cerr << "calibd-calibrate: cannot write '" << path << "'\n";
        return 1;
      }
    }
  }

  if (!html_path.empty()) {
    const auto t_html = std::chrono::steady_clock::now();
    html.outcome = out;
    html.gates = engine.verdict;
    html.camera_frame = config.camera_frame;
    html.lidar_frame = config.lidar_frame;
    html.board_names = tools::BoardNames(config.boards);
    html.reprojection = tools::ReprojectionPerCorrespondence(corr, reprojection_px);
    html.truth_rotation_deg = truth_rot;
    html.truth_translation_m = truth_trans;
    tools::ReportProvenance& p = html.provenance;
    p.software_version = std::string("calibd ") + CALIBD_VERSION;
    p.input_path = folder_path.empty() ? log_path : folder_path + " (folder)";
    p.config_path = config_path;
    std::string config_bytes;
    if (ReadWholeFile(config_path, &config_bytes, &error))
      p.config_sha256 = tools::Sha256Hex(config_bytes);
    p.method = method;
    p.generated_unix_s = static_cast<int64_t>(std::time(nullptr));
    p.camera_frames = stats.camera_frames;
    p.lidar_frames = stats.lidar_frames;
    p.pairs = stats.pairs;
    p.unpaired_camera = stats.unpaired_camera;
    p.unpaired_lidar = stats.unpaired_lidar;
    p.bad_messages = stats.bad_messages;
    p.camera_boards = static_cast<int>(session.camera.size());
    p.lidar_boards = static_cast<int>(session.lidar.size());
    if (!tools::WriteHtmlReport(html_path, html, &error)) {
      std::cerr << "calibd-calibrate: " << error << "\n";
      return 1;
    }
    if (!quiet)
      std::cerr << "calibd-calibrate: HTML report " << html_path << " in " << MsSince(t_html)
                << " ms (pictures rendered before)\n";
  }

  if (!quiet) {
    const Eigen::Vector3d xyz = out.T_camera_lidar.translation();
    std::cout << std::fixed << std::setprecision(4) << "verdict: " << VerdictName(out.verdict)
              << (out.reason == Reason::kNone ? "" : " (" + std::string(NameOf(out.reason)) + ")")
              << ": " << out.detail << "\n"
              << "T_camera_lidar xyz [m]: " << xyz.transpose() << "\n"
              << "change vs prior: " << out.delta_rotation_deg << " deg, "
              << out.delta_translation_m << " m\n";
    if (!lidar_hint.empty()) std::cout << "hint: " << lidar_hint << "\n";
    if (truth_rot >= 0.0)
      std::cout << "error vs truth: " << truth_rot << " deg, " << truth_trans << " m\n";
    std::cout << std::setprecision(2) << "quality: reprojection " << q.reprojection_mean_px
              << " px mean (p95 " << q.reprojection_p95_px << "), residual "
              << q.residual_rms_m * 100.0 << " cm RMS, " << q.frames_used << " frames, "
              << q.boards_used << " boards, " << q.min_distance_m << "-" << q.max_distance_m
              << " m\n"
              << std::setprecision(1) << "time: detection " << read_s << " s for " << stats.pairs
              << " pairs (camera median " << Median(stats.camera_ms) << " ms, LiDAR median "
              << Median(stats.lidar_ms) << " ms), grid search " << out.grid.search_ms
              << " ms, optimisation " << out.optimise_ms << " ms\n";
  }
  return out.verdict == CalibrationOutcome::Verdict::kRejected ? 3 : 0;
}
