// calibd-calibrate: calibrates T_camera_lidar offline from a recorded session (LCM log or a
// folder of recorded frames) and a calibration config, and writes a JSON report, exports,
// overlay pictures and an HTML page on request. See --help. main() reads as its steps: options,
// config, the session read and detected, the solve, then each output asked for.

#include <algorithm>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <optional>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/core/common/stats.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/text_format.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"
#include "calibration_run.hpp"
#include "command_line.hpp"
#include "html_report.hpp"
#include "inspect.hpp"
#include "lidar_model_source.hpp"
#include "log_session.hpp"
#include "result_pictures.hpp"
#include "tool_config.hpp"

namespace {

using namespace calibd;
using tools::CalibrationRun;

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

constexpr int kExitSolved = 0, kExitFailed = 1, kExitRejected = 3;  // and kExitBadOption (2)
const std::string kSoftwareVersion = std::string("calibd ") + CALIBD_VERSION;

struct Options {
  std::string log_path, folder_path, intrinsics_path, config_path;
  std::string report_path, export_dir, overlay_dir, html_path, truth_path;
  // Given on the command line: then over the config's engine section.
  std::optional<std::string> method;
  std::optional<bool> motion_compensation, board_pose_refinement;
  tools::LogReadOptions read;
  bool quiet = false;
  bool inspect = false;
  tools::InspectOptions inspect_options;
};

int Fail(int code, const std::string& message) {
  std::cerr << "calibd-calibrate: " << message << "\n";
  return code;
}

// The command line into `o`: -1 to go on, else the exit code (0 after --help, 2 for a bad option).
int ParseOptions(int argc, char** argv, Options* o) {
  // Offline, the time plane extraction costs (tens of ms a frame) buys the boards of cluttered
  // still poses (recordings from other rigs).
  o->read.lidar.extract_planes = true;
  tools::CommandLine line("calibd-calibrate", argc, argv);
  while (line.Next()) {
    long n = 0;
    double ms = 0.0;
    bool on = false;
    std::string text;
    if (line.Is("--help") || line.Is("-h")) {
      std::cout << tools::HelpWithFramesCsv(kHelp);
      return 0;
    } else if (line.Is("--quiet")) {
      o->quiet = true;
    } else if (line.Is("--inspect")) {
      o->inspect = true;
    } else if (line.Is("--log")) {
      line.Value(&o->log_path);
    } else if (line.Is("--folder")) {
      line.Value(&o->folder_path);
    } else if (line.Is("--intrinsics")) {
      line.Value(&o->intrinsics_path);
    } else if (line.Is("--config")) {
      line.Value(&o->config_path);
    } else if (line.Is("--report")) {
      line.Value(&o->report_path);
    } else if (line.Is("--overlay")) {
      line.Value(&o->overlay_dir);
    } else if (line.Is("--html")) {
      line.Value(&o->html_path);
    } else if (line.Is("--export")) {
      line.Value(&o->export_dir);
    } else if (line.Is("--debug")) {
      line.Value(&o->read.debug_dir);
    } else if (line.Is("--truth")) {
      line.Value(&o->truth_path);
    } else if (line.Is("--mounting")) {
      line.Value(&o->inspect_options.mounting);
    } else if (line.Is("--write-config")) {
      line.Value(&o->inspect_options.config_out);
    } else if (line.Is("--method")) {
      if (line.Value(&text)) o->method = text;
    } else if (line.Is("--extract-planes")) {
      line.OnOff(&o->read.lidar.extract_planes);
    } else if (line.Is("--motion-compensation")) {
      if (line.OnOff(&on)) o->motion_compensation = on;
    } else if (line.Is("--board-pose-refinement")) {
      if (line.OnOff(&on)) o->board_pose_refinement = on;
    } else if (line.Is("--max-frames")) {
      if (line.Integer(1, 100000, &n)) o->read.max_frames = static_cast<int>(n);
    } else if (line.Is("--pair-tolerance-ms")) {
      if (line.Number(0.0, 1000.0, &ms))
        o->read.pair_tolerance_us = static_cast<int64_t>(ms * 1000.0);
    } else {
      line.Unknown();
    }
  }
  if (!line.failed() && o->inspect &&
      (o->folder_path.empty() || !o->log_path.empty() || !o->config_path.empty()))
    line.Error("--inspect needs --folder DIR and no --log or --config (see --help)");
  if (!line.failed() && !o->inspect &&
      (o->log_path.empty() == o->folder_path.empty() || o->config_path.empty()))
    line.Error("--config and one of --log or --folder are required (see --help)");
  if (!line.failed() && o->method && *o->method != "direct" && *o->method != "indirect")
    line.Error("--method must be direct or indirect (got '" + *o->method + "')");
  return line.failed() ? line.Fail(std::cerr) : -1;
}

// The log or the folder, read the same way (pairing, detection, counters); `keep` and `kept`
// as ReadSessionLog's.
bool ReadPairs(const Options& o, const CalibConfig& config, const tools::LogReadOptions& read,
               SessionObservations* into, tools::LogReadStats* stats, std::string* error,
               const std::function<void(int)>& progress = {}, const std::vector<int>& keep = {},
               std::vector<tools::FramePairData>* kept = nullptr) {
  return o.folder_path.empty() ? tools::ReadSessionLog(o.log_path, config, read, into, stats, error,
                                                       progress, keep, kept)
                               : tools::ReadSessionFolder(o.folder_path, config, read, into, stats,
                                                          error, progress, keep, kept);
}

// The LiDAR model (for generic, estimated from the first frames and shown to the user), then
// every frame pair read and detected into `run`. An exit code on failure, -1 to go on.
int ReadSession(const Options& o, const CalibConfig& config, CalibrationRun* run) {
  std::string error;
  if (!tools::LidarModelForSession({o.log_path, o.folder_path}, config, &run->lidar_model,
                                   &run->lidar_estimate, &error))
    return Fail(kExitFailed, error);
  if (!o.quiet && run->lidar_model.kind == LidarKind::kGeneric)
    std::cerr << "calibd-calibrate: "
              << DescribeGenericLidar(run->lidar_model, &run->lidar_estimate) << "\n";
  if (!o.read.debug_dir.empty() && !CreateDirectories(o.read.debug_dir, &error))
    return Fail(tools::kExitBadOption, "--debug: " + error);
  run->read = o.read;
  run->read.lidar_model = run->lidar_model;
  const auto t_start = SteadyClock::now();
  auto progress = [&](int pairs) {
    if (!o.quiet) std::cerr << "calibd-calibrate: " << pairs << " frame pairs detected\n";
  };
  if (!ReadPairs(o, config, run->read, &run->session, &run->stats, &error, progress))
    return Fail(kExitFailed, error);
  const tools::LogReadStats& stats = run->stats;
  if (stats.debug_write_failures > 0)
    std::cerr << "calibd-calibrate: warning: " << stats.debug_write_failures
              << " --debug file(s) not written (first: " << stats.first_debug_error << ")\n";
  if (stats.padded_clouds > 0)
    std::cerr << "calibd-calibrate: warning: " << stats.padded_clouds
              << " binary PCD file(s) have bytes after their last point, ignored as PCL ignores "
                 "them (first: "
              << stats.first_padded_cloud << ")\n";
  run->read_s = SecondsSince(t_start);
  return -1;
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

// The engine on the session, with the command line's choices over the config's engine section;
// the causes and hints a user can act on.
void Solve(const Options& o, const CalibConfig& config, EngineConfig* engine, CalibrationRun* run) {
  if (o.method)
    engine->method =
        *o.method == "indirect" ? EngineConfig::Method::kIndirect : EngineConfig::Method::kDirect;
  if (o.motion_compensation) engine->motion.enabled = *o.motion_compensation;
  // Pairs by name stem carry made-up times: no velocity can be fitted to them, whatever the
  // window.
  if (run->stats.pseudo_times) engine->motion.enabled = false;
  if (o.board_pose_refinement) engine->direct.refine_board_poses = *o.board_pose_refinement;
  run->method = engine->method == EngineConfig::Method::kIndirect ? "indirect" : "direct";
  CalibrationOutcome& out = run->outcome;
  out = Calibrate(config, run->session, SessionProjection(run->lidar_model), *engine,
                  &run->correspondences, &run->reprojection_px);
  // Without a single frame pair the input is the cause, not the boards: say what it lacked.
  bool lidar_cause = false;
  const std::string no_pairs =
      tools::NoPairsCause(run->stats, config, !o.folder_path.empty(), &lidar_cause);
  if (!no_pairs.empty() && !out.solved) {
    out.reason = lidar_cause ? Reason::kNoLidarBoards : Reason::kNoCameraBoards;
    out.detail = no_pairs;
  }
  run->lidar_hint =
      LidarMissHint(run->session, run->correspondences, engine->max_solve_frames, run->lidar_model);
  if (out.motion.FramesBeyondWindow())
    run->motion_hint =
        "the frame pairs lie " + FixedDecimal(out.motion.frame_interval_s, 2) +
        " s apart, beyond the +-" + FixedDecimal(out.motion.window_s, 2) +
        " s in which board velocities are fitted, so no board's motion was measured or "
        "compensated: if the boards moved against the car (driving, boards carried), set "
        "engine.motion_window_s to " +
        FixedDecimal(std::min(1.5 * out.motion.frame_interval_s, kMaxMotionWindowS), 2) +
        " in the config";
  if (!run->motion_hint.empty() && !o.quiet)
    std::cerr << "calibd-calibrate: note: " << run->motion_hint << "\n";
}

// --truth: the simulator's truth JSON, for the error against it (evaluation only).
bool CompareWithTruth(const std::string& truth_path, CalibrationRun* run, std::string* error) {
  std::string text;
  if (!ReadWholeFile(truth_path, &text, error)) return false;
  try {
    const auto truth = nlohmann::json::parse(text);
    Pose T = Pose::Identity();
    for (int r = 0; r < 3; ++r)
      for (int c = 0; c < 4; ++c)
        T.matrix()(r, c) = truth.at("T_camera_lidar").at(r).at(c).get<double>();
    const Pose& result = run->outcome.T_camera_lidar;
    run->truth_rotation_deg = RotationAngle(result.linear(), T.linear()) * kRad2Deg;
    run->truth_translation_m = (result.translation() - T.translation()).norm();
    return true;
  } catch (const std::exception& e) {
    *error = "truth file '" + truth_path + "': " + e.what();
    return false;
  }
}

// --export: the result in other stacks' formats. A rejected result is no calibration to hand on:
// other stacks would load it without a verdict.
bool WriteExports(const std::string& dir, const CalibrationRun& run, const CalibConfig& config,
                  std::string* error) {
  if (run.outcome.verdict == CalibrationOutcome::Verdict::kRejected) return true;
  CalibrationExport e;
  e.T_camera_lidar = run.outcome.T_camera_lidar;
  e.camera_frame = config.camera_frame;
  e.lidar_frame = config.lidar_frame;
  e.software_version = kSoftwareVersion;
  e.calibrated_unix_s = static_cast<int64_t>(std::time(nullptr));
  return WriteCalibrationExports(dir, e, error);
}

// --html: the page, with the pictures already drawn into `html.images`.
bool WriteHtml(const Options& o, const CalibrationRun& run, const CalibConfig& config,
               const EngineConfig& engine, tools::HtmlReportInput html, std::string* error) {
  const auto t_html = SteadyClock::now();
  html.outcome = run.outcome;
  html.gates = engine.verdict;
  html.camera = config.camera;
  html.camera_frame = config.camera_frame;
  html.lidar_frame = config.lidar_frame;
  html.board_names = tools::BoardNames(config.boards);
  html.reprojection =
      tools::ReprojectionPerCorrespondence(run.correspondences, run.reprojection_px);
  html.truth_rotation_deg = run.truth_rotation_deg;
  html.truth_translation_m = run.truth_translation_m;
  tools::ReportProvenance& p = html.provenance;
  p.software_version = kSoftwareVersion;
  p.input_path = o.folder_path.empty() ? o.log_path : o.folder_path + " (folder)";
  p.config_path = o.config_path;
  std::string config_bytes;
  if (ReadWholeFile(o.config_path, &config_bytes, error))
    p.config_sha256 = tools::Sha256Hex(config_bytes);
  p.method = run.method;
  p.generated_unix_s = static_cast<int64_t>(std::time(nullptr));
  const tools::LogReadStats& stats = run.stats;
  p.camera_frames = stats.camera_frames;
  p.lidar_frames = stats.lidar_frames;
  p.pairs = stats.pairs;
  p.unpaired_camera = stats.unpaired_camera;
  p.unpaired_lidar = stats.unpaired_lidar;
  p.bad_messages = stats.bad_messages;
  p.camera_boards = static_cast<int>(run.session.camera.size());
  p.lidar_boards = static_cast<int>(run.session.lidar.size());
  if (!tools::WriteHtmlReport(o.html_path, html, error)) return false;
  if (!o.quiet)
    std::cerr << "calibd-calibrate: HTML report " << o.html_path << " in " << MsSince(t_html)
              << " ms (pictures rendered before)\n";
  return true;
}

// The console summary: verdict, result, change, hint, quality and time.
void PrintSummary(const CalibrationRun& run) {
  const CalibrationOutcome& out = run.outcome;
  const QualityFigures& q = out.quality;
  const tools::LogReadStats& stats = run.stats;
  const Eigen::Vector3d xyz = out.T_camera_lidar.translation();
  std::cout << std::fixed << std::setprecision(4) << "verdict: " << VerdictName(out.verdict)
            << (out.reason == Reason::kNone ? "" : " (" + std::string(NameOf(out.reason)) + ")")
            << ": " << out.detail << "\n"
            << "T_camera_lidar xyz [m]: " << xyz.transpose() << "\n"
            << "change vs prior: " << out.delta_rotation_deg << " deg, " << out.delta_translation_m
            << " m\n";
  if (!run.lidar_hint.empty()) std::cout << "hint: " << run.lidar_hint << "\n";
  if (run.truth_rotation_deg >= 0.0)
    std::cout << "error vs truth: " << run.truth_rotation_deg << " deg, " << run.truth_translation_m
              << " m\n";
  std::cout << std::setprecision(2) << "quality: reprojection " << q.reprojection_mean_px
            << " px mean (p95 " << q.reprojection_p95_px << "), residual "
            << q.residual_rms_m * 100.0 << " cm RMS, " << q.frames_used << " frames, "
            << q.boards_used << " boards, " << q.min_distance_m << "-" << q.max_distance_m << " m\n"
            << std::setprecision(1) << "time: detection " << run.read_s << " s for " << stats.pairs
            << " pairs (camera median " << Median(stats.camera_ms) << " ms, LiDAR median "
            << Median(stats.lidar_ms) << " ms), grid search " << out.grid.search_ms
            << " ms, optimisation " << out.optimise_ms << " ms\n";
}

}  // namespace

int main(int argc, char** argv) {
  Options o;
  if (const int code = ParseOptions(argc, argv, &o); code >= 0) return code;
  if (o.inspect) {
    o.inspect_options.folder = o.folder_path;
    o.inspect_options.intrinsics_path = o.intrinsics_path;
    return tools::RunInspect(o.inspect_options, std::cout, std::cerr);
  }

  // The config may hold the agent's sections: `engine:` is read as the agent reads it, `agent:`
  // is the agent's own.
  std::string error, config_text;
  CalibConfig config;
  EngineConfig engine;
  if (!tools::LoadToolConfig(o.config_path, o.intrinsics_path, {"engine", "agent"}, &config,
                             &config_text, &error))
    return Fail(tools::kExitBadOption, error);
  if (!ParseEngineConfigYaml(config_text, &engine, &error))
    return Fail(tools::kExitBadOption, o.config_path + ": " + error);

  CalibrationRun run;
  if (const int code = ReadSession(o, config, &run); code >= 0) return code;
  Solve(o, config, &engine, &run);
  if (!o.truth_path.empty() && !CompareWithTruth(o.truth_path, &run, &error))
    return Fail(kExitFailed, error);

  if (!o.report_path.empty() &&
      !WriteFileAtomic(o.report_path,
                       tools::ReportJson(run, config, kSoftwareVersion).dump(2) + "\n", &error))
    return Fail(kExitFailed, error);
  if (!o.export_dir.empty() && !WriteExports(o.export_dir, run, config, &error))
    return Fail(kExitFailed, error);
  tools::HtmlReportInput html;
  if (!o.overlay_dir.empty() || !o.html_path.empty()) {
    // The pictures' pairs read again: only their data (they were detected above).
    tools::LogReadOptions pictures_only = run.read;
    pictures_only.detect = false;
    auto read_pairs = [&](const std::vector<int>& pairs, std::vector<tools::FramePairData>* kept,
                          std::string* read_error) {
      SessionObservations unused;
      tools::LogReadStats unused_stats;
      return ReadPairs(o, config, pictures_only, &unused, &unused_stats, read_error, {}, pairs,
                       kept);
    };
    if (!tools::DrawResultPictures(run, config, engine, read_pairs, o.overlay_dir,
                                   o.html_path.empty() ? nullptr : &html.images, &error))
      return Fail(kExitFailed, error);
  }
  if (!o.html_path.empty() && !WriteHtml(o, run, config, engine, std::move(html), &error))
    return Fail(kExitFailed, error);
  if (!o.quiet) PrintSummary(run);
  return run.outcome.verdict == CalibrationOutcome::Verdict::kRejected ? kExitRejected
                                                                       : kExitSolved;
}
