// calibd-sim: simulates a workshop calibration session (camera + LiDAR frames of square AprilTag
// boards) with a known extrinsic. See --help.

#include <cstdint>
#include <iostream>
#include <string>
#include <vector>

#include "command_line.hpp"
#include "live_publisher.hpp"
#include "run.hpp"

namespace {

using calibd::sim::SessionOptions;
using calibd::sim::SimOutputs;

constexpr const char* kHelp =
    R"(calibd-sim: simulate a workshop calibration session with a known extrinsic.

Writes an LCM log of camera and LiDAR frames (the channels of calibd's registry), and optionally
the ground truth (for evaluation only) and the calibration config a user would write.

Usage: calibd-sim --out session.lcmlog [--truth truth.json] [--config-out calib.yaml] [options]
       calibd-sim --folder DIR [--no-frames-csv] [--truth truth.json] [--config-out calib.yaml]
                  [options]
       calibd-sim --replay session.lcmlog --publish-url URL [--loops N] [--speed X]

Output:
  --out FILE               LCM log to write. Event timestamps are capture times.
  --folder DIR             and/or a folder of recorded frames as other tools write them (for
                           calibd-calibrate --folder and calibd-import): NNNNNN.pcd (binary PCD:
                           x y z intensity, ring for sensors with rings, t in s after the sweep
                           start) and NNNNNN.png (.jpg with --image-encoding jpeg), and
                           frames.csv with their capture times (DIR is created)
  --no-frames-csv          no frames.csv: the pairs go by file name, without times
  --truth FILE             ground-truth JSON: true/prior extrinsic, intrinsics, board poses per
                           frame, indices of the LiDAR points on each board
  --config-out FILE        calibration config YAML (intrinsics, boards, LiDAR model, perturbed prior)
  --overlay-png FILE       picture of one frame with LiDAR points projected (true extrinsic)
  --overlay-frame N        frame for --overlay-png (default 0)
  --overlay-scale S        size of that picture relative to the image (default 0.5)
  --quiet                  no progress or summary
Live publishing (instead of simulating; as the sensor drivers would publish):
  --replay FILE            LCM log to publish (written by --out)
  --publish-url URL        LCM URL, e.g. 'udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216'
  --loops N                play the log N times, capture times shifted so that time keeps going
                           forward (a 200-frame log 10 times: a 2000-frame session) (default 1)
  --speed X                1 = real time (default 1)
  --start-delay S          wait S seconds before the first event (default 0.5)
Session:
  --seed N                 random seed; same seed, same output (default 1)
  --lidar MODEL            ot128 | m1 | falcon | vlp16 | vlp32c | os1-64 | avia | mid360
                           (default ot128)
  --trajectory MODE        drive (back and forth) | static | close (6-8.5 m) | far (25-30 m) |
                           stills: parked while the boards are moved between frames (on a
                           tripod or held by a person, turned, with a chair, a wall, a box or a
                           bystander within 0.3-1 m), one still pose a frame (default drive)
  --still-distance MIN,MAX stills: LiDAR to board distance, m (default 1.5,8)
  --frames-per-pose N      stills: N frame pairs per pose, one LiDAR sweep apart, as a stream
                           recorded while the board stood still (default 1); --frames and
                           --duration count poses
  --occluded-share S       stills, fault: someone stands 0.4-0.8 m in front of every board,
                           hiding about this share of its width, 0-0.5 (default 0)
  --board-speed V          stills, fault: the boards are still carried at V m/s (0-3) while a
                           pose's frames are taken, each in a horizontal direction of its own;
                           each sensor sees them at its own time (default 0)
  --distance MIN,MAX       drive range from the LiDAR to the boards, m (default 6,30)
  --static-distance M      distance in static mode, m (default 10)
  --duration S             session length, s (default 20)
  --rate HZ                frame pairs per second (default 10)
  --frames N               number of frame pairs (sets --duration to N / rate)
Boards and scene:
  --boards N               number of boards (default 3)
  --board-size W[,H]       board size, m (default 0.6)
  --tag-size M             side of the tag's black square, m (default 0.48)
  --tag-family NAME        tag36h11 | tag25h9 | tag16h5 | tagStandard41h12 (default tag36h11)
  --tag-ids A,B,...        tag id of each board (default 0,1,2,...)
  --board-scales A,B,...   each board's sizes (board, tag, checker squares) times this factor,
                           0.2-1: boards of several sizes (default all 1)
  --board-bows A,B,...     fault: each board's face bent about its vertical centre line,
                           bulging this much there towards the sensors (m, negative: away,
                           within +-0.1; default flat)
  --checkerboard I,R,C,S   board I (0-based) carries a checkerboard instead of a tag: R x C
                           inner corners, squares of S m (e.g. 2,5,7,0.07)
  --layout NAME            spread | line | stack (default spread)
  --board-spacing M        lateral distance between boards, m (default 2.2)
  --no-clutter             no poles, crates, car, people or door panel
  --no-walls               no walls
LiDAR noise:
  --range-noise M          range sigma, m (default 0.02)
  --angular-jitter DEG     beam direction sigma, deg (default 0.01)
  --dropout P              probability a return is lost (default 0.02)
  --beam-divergence MRAD   beam footprint for mixed edge points, mrad (default 2)
  --range-bias M           fault: constant added to every range, m (default 0)
Camera:
  --width PX --height PX   image size (default 3840 x 1920)
  --camera-delay-us US     fault: the camera exposes this long after its trigger; the LiDAR
                           keeps its phase (a camera running behind; default 0)
  --camera-readout-us US   fault: a rolling shutter reading its rows out top to bottom over
                           this long, the first at the capture time (default 0: global)
  --fx PX --fy PX          focal lengths (default 3325)
  --cx PX --cy PX          principal point (default image centre)
  --distortion K1,K2,P1,P2,K3   radial-tangential coefficients (default -0.08,0.03,0.0005,-0.0003,-0.005)
  --blur PX                optical blur sigma (default 0.7)
  --image-noise DN         sensor noise sigma, grey levels (default 2)
  --exposure MIN,MAX       per-frame exposure gain range (default 0.8,1.2)
  --image-encoding ENC     mono8 (raw, 7.4 MB a frame) | jpeg (about 10x smaller) (default mono8)
  --jpeg-quality Q         JPEG quality 1-100 (default 95)
Extrinsic (vehicle frame: x forward, y left, z up; angles in degrees):
  --lidar-mount X,Y,Z,ROLL,PITCH,YAW    (default 1.2,0,1.95,0,0,0)
  --camera-mount X,Y,Z,ROLL,PITCH,YAW   forward-looking body angles (default 1.6,0.05,1.45,0.5,2,-0.8)
                           true T_camera_lidar = T_vehicle_camera^-1 * T_vehicle_lidar
  --prior-rot-deg D        rotation error of the prior, deg, within +-10 (default 5)
  --prior-rot-axis X,Y,Z   axis of that error (default: random from the seed)
  --prior-trans-m M        translation error of the prior, m, random direction (default 0.05)
Identity:
  --camera-id ID --lidar-id ID          sensor ids in the messages (default front, roof)
  --camera-serial S --lidar-serial S    serial numbers in sensor_info messages

Exit codes: 0 done, 1 failed while writing, 2 bad option.
)";

// What the command line asks for: a simulated session (`options`, `outputs`) or a replay (`live`).
struct SimCommandLine {
  SessionOptions options;
  SimOutputs outputs;
  calibd::sim::LivePublishOptions live;
  bool quiet = false, help = false;
};

// The command line into `s` (the camera's principal point defaults to the image centre, --frames
// sets the duration); false, with the error in `line`, on a bad option.
bool ParseOptions(calibd::tools::CommandLine& line, SimCommandLine* s) {
  SessionOptions& o = s->options;
  SimOutputs& out = s->outputs;
  calibd::sim::LivePublishOptions& live = s->live;
  live.start_delay_s = 0.5;
  bool cx_set = false, cy_set = false;
  long frames = -1, n = 0;
  std::vector<double> v;
  line.AcceptInlineValues();  // --option=VALUE, as this tool always took
  while (line.Next()) {
    if (line.Is("--help") || line.Is("-h")) {
      s->help = true;
    } else if (line.Is("--quiet")) {
      s->quiet = true;
    } else if (line.Is("--no-frames-csv")) {
      out.folder_without_times = true;
    } else if (line.Is("--no-clutter")) {
      o.workshop.clutter = false;
    } else if (line.Is("--no-walls")) {
      o.workshop.walls = false;
    } else if (line.Is("--out")) {
      line.Text(&out.log_path);
    } else if (line.Is("--folder")) {
      line.Text(&out.folder_path);
    } else if (line.Is("--replay")) {
      line.Text(&live.log_path);
    } else if (line.Is("--publish-url")) {
      line.Text(&live.url);
    } else if (line.Is("--loops")) {
      line.Integer(1, 1000000, &live.loops);
    } else if (line.Is("--speed")) {
      line.Number(0.01, 100, &live.speed);
    } else if (line.Is("--start-delay")) {
      line.Number(0, 60, &live.start_delay_s);
    } else if (line.Is("--truth")) {
      line.Text(&out.truth_path);
    } else if (line.Is("--config-out")) {
      line.Text(&out.config_path);
    } else if (line.Is("--overlay-png")) {
      line.Text(&out.overlay_path);
    } else if (line.Is("--overlay-frame")) {
      line.Integer(0, 1000000, &out.overlay_frame);
    } else if (line.Is("--overlay-scale")) {
      line.Number(0.05, 1.0, &out.overlay_scale);
    } else if (line.Is("--seed")) {
      if (line.Integer(0, 9000000000000000L, &n)) o.seed = static_cast<uint64_t>(n);
    } else if (line.Is("--lidar")) {
      line.Text(&o.lidar_model);
    } else if (line.Is("--trajectory")) {
      line.Text(&o.trajectory.mode);
    } else if (line.Is("--distance")) {
      if (line.Numbers({2, 2}, &v)) {
        o.trajectory.min_distance_m = v[0];
        o.trajectory.max_distance_m = v[1];
      }
    } else if (line.Is("--static-distance")) {
      line.Number(1, 150, &o.trajectory.static_distance_m);
    } else if (line.Is("--still-distance")) {
      if (line.Numbers({2, 2}, &v)) {
        o.stills.min_distance_m = v[0];
        o.stills.max_distance_m = v[1];
      }
    } else if (line.Is("--frames-per-pose")) {
      line.Integer(1, 100, &o.stills.frames_per_pose);
    } else if (line.Is("--occluded-share")) {
      line.Number(0, 0.5, &o.stills.occluded_share);
    } else if (line.Is("--board-speed")) {
      line.Number(0, 3, &o.stills.board_speed_mps);
    } else if (line.Is("--duration")) {
      line.Number(0.1, 3600, &o.trajectory.duration_s);
    } else if (line.Is("--rate")) {
      line.Number(0.1, 50, &o.trajectory.rate_hz);
    } else if (line.Is("--frames")) {
      line.Integer(1, 100000, &frames);
    } else if (line.Is("--boards")) {
      line.Integer(1, 12, &o.workshop.num_boards);
    } else if (line.Is("--board-size")) {
      if (line.Numbers({1, 2}, &v)) {
        o.workshop.board_width_m = v[0];
        o.workshop.board_height_m = v.back();
      }
    } else if (line.Is("--tag-size")) {
      line.Number(0.01, 5, &o.workshop.tag_size_m);
    } else if (line.Is("--tag-family")) {
      line.Text(&o.workshop.tag_family);
    } else if (line.Is("--tag-ids")) {
      if (line.Numbers({1, 12}, &v)) o.workshop.tag_ids.assign(v.begin(), v.end());
    } else if (line.Is("--board-scales")) {
      line.Numbers({1, 12}, &o.workshop.board_scales);
    } else if (line.Is("--board-bows")) {
      line.Numbers({1, 12}, &o.workshop.board_bows_m);
    } else if (line.Is("--checkerboard")) {
      if (line.Numbers({4, 4}, &v)) {
        o.workshop.checkerboard_board = static_cast<int>(v[0]);
        o.workshop.checker_inner_rows = static_cast<int>(v[1]);
        o.workshop.checker_inner_cols = static_cast<int>(v[2]);
        o.workshop.checker_square_m = v[3];
      }
    } else if (line.Is("--layout")) {
      line.Text(&o.workshop.layout);
    } else if (line.Is("--board-spacing")) {
      line.Number(0.1, 20, &o.workshop.board_spacing_m);
    } else if (line.Is("--range-noise")) {
      line.Number(0, 0.5, &o.lidar_noise.range_sigma_m);
    } else if (line.Is("--angular-jitter")) {
      line.Number(0, 1, &o.lidar_noise.angular_jitter_deg);
    } else if (line.Is("--dropout")) {
      line.Number(0, 0.99, &o.lidar_noise.dropout_probability);
    } else if (line.Is("--beam-divergence")) {
      line.Number(0, 20, &o.lidar_noise.beam_divergence_mrad);
    } else if (line.Is("--range-bias")) {
      line.Number(-1, 1, &o.lidar_noise.range_bias_m);
    } else if (line.Is("--camera-delay-us")) {
      if (line.Integer(-1000000, 1000000, &n)) o.camera_delay_us = n;
    } else if (line.Is("--camera-readout-us")) {
      if (line.Integer(0, 200000, &n)) o.camera_readout_us = n;
    } else if (line.Is("--width")) {
      line.Integer(16, 16384, &o.camera.width);
    } else if (line.Is("--height")) {
      line.Integer(16, 16384, &o.camera.height);
    } else if (line.Is("--fx")) {
      line.Number(1, 1e5, &o.camera.fx);
    } else if (line.Is("--fy")) {
      line.Number(1, 1e5, &o.camera.fy);
    } else if (line.Is("--cx")) {
      cx_set = line.Number(0, 16384, &o.camera.cx);
    } else if (line.Is("--cy")) {
      cy_set = line.Number(0, 16384, &o.camera.cy);
    } else if (line.Is("--distortion")) {
      if (line.Numbers({5, 5}, &v)) {
        o.camera.k1 = v[0];
        o.camera.k2 = v[1];
        o.camera.p1 = v[2];
        o.camera.p2 = v[3];
        o.camera.k3 = v[4];
      }
    } else if (line.Is("--blur")) {
      line.Number(0, 10, &o.imaging.blur_sigma_px);
    } else if (line.Is("--image-noise")) {
      line.Number(0, 50, &o.imaging.noise_sigma);
    } else if (line.Is("--exposure")) {
      if (line.Numbers({2, 2}, &v)) {
        o.imaging.exposure_min = v[0];
        o.imaging.exposure_max = v[1];
      }
    } else if (line.Is("--image-encoding")) {
      line.Text(&o.image_encoding);
    } else if (line.Is("--jpeg-quality")) {
      line.Integer(1, 100, &o.jpeg_quality);
    } else if (line.Is("--lidar-mount")) {
      if (line.Numbers({6, 6}, &v))
        for (int i = 0; i < 6; ++i) o.lidar_mount[i] = v[static_cast<size_t>(i)];
    } else if (line.Is("--camera-mount")) {
      if (line.Numbers({6, 6}, &v))
        for (int i = 0; i < 6; ++i) o.camera_mount[i] = v[static_cast<size_t>(i)];
    } else if (line.Is("--prior-rot-deg")) {
      line.Number(-10, 10, &o.prior_rot_deg);
    } else if (line.Is("--prior-rot-axis")) {
      if (line.Numbers({3, 3}, &v)) o.prior_rot_axis = {v[0], v[1], v[2]};
    } else if (line.Is("--prior-trans-m")) {
      line.Number(-0.5, 0.5, &o.prior_trans_m);
    } else if (line.Is("--camera-id")) {
      line.Text(&o.camera_id);
    } else if (line.Is("--lidar-id")) {
      line.Text(&o.lidar_id);
    } else if (line.Is("--camera-serial")) {
      line.Text(&o.camera_serial);
    } else if (line.Is("--lidar-serial")) {
      line.Text(&o.lidar_serial);
    } else {
      line.Unknown();
    }
  }
  if (!cx_set) o.camera.cx = (o.camera.width - 1) / 2.0;
  if (!cy_set) o.camera.cy = (o.camera.height - 1) / 2.0;
  if (frames > 0) o.trajectory.duration_s = static_cast<double>(frames) / o.trajectory.rate_hz;
  return !line.failed();
}

}  // namespace

int main(int argc, char** argv) {
  SimCommandLine s;
  calibd::tools::CommandLine line("calibd-sim", argc, argv);
  if (!ParseOptions(line, &s)) return line.Fail(std::cerr);
  const SessionOptions& o = s.options;
  const SimOutputs& out = s.outputs;
  const calibd::sim::LivePublishOptions& live = s.live;
  const bool quiet = s.quiet;
  if (s.help) {
    std::cout << kHelp;
    return 0;
  }
  if (!live.log_path.empty() || !live.url.empty()) {
    if (live.log_path.empty() || live.url.empty()) {
      std::cerr << "calibd-sim: --replay and --publish-url go together (see --help)\n";
      return calibd::tools::kExitBadOption;
    }
    calibd::sim::LivePublishSummary published;
    std::string error;
    if (!calibd::sim::PublishLive(live, &published, quiet ? nullptr : &std::cerr, &error)) {
      std::cerr << "calibd-sim: " << error << "\n";
      return 1;
    }
    if (!quiet)
      std::cout << "calibd-sim: published " << published.camera << " camera and " << published.lidar
                << " LiDAR frames, " << published.other << " other events ("
                << published.bytes / 1000000 << " MB) in " << published.duration_s << " s; "
                << published.late << " events more than a frame period late (max "
                << published.max_lateness_ms << " ms)\n";
    return 0;
  }
  if (out.log_path.empty() && out.folder_path.empty()) {
    std::cerr << "calibd-sim: --out FILE or --folder DIR is required (see --help)\n";
    return calibd::tools::kExitBadOption;
  }
  std::string error;
  if (!o.IsValid(&error)) {
    std::cerr << "calibd-sim: " << error << "\n";
    return calibd::tools::kExitBadOption;
  }
  calibd::sim::SimSummary summary;
  if (!calibd::sim::RunSimulation(o, out, &summary, quiet ? nullptr : &std::cerr, &error)) {
    std::cerr << "calibd-sim: " << error << "\n";
    return 1;
  }
  if (!quiet) {
    std::cout << "calibd-sim: wrote "
              << (out.log_path.empty() ? out.folder_path + "/" : out.log_path);
    if (!out.log_path.empty() && !out.folder_path.empty()) std::cout << ", " << out.folder_path;
    if (!out.truth_path.empty()) std::cout << ", " << out.truth_path;
    if (!out.config_path.empty()) std::cout << ", " << out.config_path;
    if (!out.overlay_path.empty()) std::cout << ", " << out.overlay_path;
    std::cout << "\n";
    calibd::sim::PrintSummary(summary, 10, std::cout);
  }
  return 0;
}
