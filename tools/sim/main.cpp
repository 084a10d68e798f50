// calibd-sim: simulates a workshop calibration session (camera + LiDAR frames of square AprilTag
// boards) with a known extrinsic. See --help.

#include <cmath>
#include <cstdlib>
#include <functional>
#include <iostream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

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

bool ParseNumbers(const std::string& text, std::vector<double>* out) {
  out->clear();
  std::stringstream ss(text);
  std::string item;
  while (std::getline(ss, item, ',')) {
    char* end = nullptr;
    const double v = std::strtod(item.c_str(), &end);
    if (item.empty() || *end != '\0' || !std::isfinite(v)) return false;
    out->push_back(v);
  }
  return !out->empty();
}

struct Parser {
  std::map<std::string, std::function<bool(const std::string&)>> with_value;
  std::map<std::string, std::function<void()>> flags;
};

}  // namespace

int main(int argc, char** argv) {
  SessionOptions o;
  SimOutputs out;
  bool quiet = false, help = false, cx_set = false, cy_set = false;
  int frames = -1;
  calibd::sim::LivePublishOptions live;
  live.start_delay_s = 0.5;
  std::string bad;  // what was wrong with the current value

  auto number = [&](double* dst, double lo, double hi) {
    return [=, &bad](const std::string& v) {
      std::vector<double> n;
      if (!ParseNumbers(v, &n) || n.size() != 1 || n[0] < lo || n[0] > hi) {
        std::ostringstream m;
        m << "expected a number in [" << lo << ", " << hi << "]";
        bad = m.str();
        return false;
      }
      *dst = n[0];
      return true;
    };
  };
  auto integer = [&](auto* dst, double lo, double hi) {
    return [=, &bad](const std::string& v) {
      std::vector<double> n;
      if (!ParseNumbers(v, &n) || n.size() != 1 || n[0] != std::floor(n[0]) || n[0] < lo ||
          n[0] > hi) {
        std::ostringstream m;
        m << "expected an integer in [" << lo << ", " << hi << "]";
        bad = m.str();
        return false;
      }
      *dst = static_cast<std::remove_pointer_t<decltype(dst)>>(n[0]);
      return true;
    };
  };
  auto list = [&](size_t min_n, size_t max_n, std::function<void(const std::vector<double>&)> set) {
    return [=, &bad](const std::string& v) {
      std::vector<double> n;
      if (!ParseNumbers(v, &n) || n.size() < min_n || n.size() > max_n) {
        bad = min_n == max_n ? "expected " + std::to_string(min_n) + " comma-separated numbers"
                             : "expected " + std::to_string(min_n) + " to " +
                                   std::to_string(max_n) + " comma-separated numbers";
        return false;
      }
      set(n);
      return true;
    };
  };
  auto text = [&](std::string* dst) {
    return [=, &bad](const std::string& v) {
      if (v.empty()) {
        bad = "expected a non-empty value";
        return false;
      }
      *dst = v;
      return true;
    };
  };

  Parser p;
  p.with_value = {
      {"--out", text(&out.log_path)},
      {"--folder", text(&out.folder_path)},
      {"--replay", text(&live.log_path)},
      {"--publish-url", text(&live.url)},
      {"--loops", integer(&live.loops, 1, 1e6)},
      {"--speed", number(&live.speed, 0.01, 100)},
      {"--start-delay", number(&live.start_delay_s, 0, 60)},
      {"--truth", text(&out.truth_path)},
      {"--config-out", text(&out.config_path)},
      {"--overlay-png", text(&out.overlay_path)},
      {"--overlay-frame", integer(&out.overlay_frame, 0, 1e6)},
      {"--overlay-scale", number(&out.overlay_scale, 0.05, 1.0)},
      {"--seed", integer(&o.seed, 0, 9.0e15)},
      {"--lidar", text(&o.lidar_model)},
      {"--trajectory", text(&o.trajectory.mode)},
      {"--distance", list(2, 2,
                          [&](auto& n) {
                            o.trajectory.min_distance_m = n[0];
                            o.trajectory.max_distance_m = n[1];
                          })},
      {"--static-distance", number(&o.trajectory.static_distance_m, 1, 150)},
      {"--still-distance", list(2, 2,
                                [&](auto& n) {
                                  o.stills.min_distance_m = n[0];
                                  o.stills.max_distance_m = n[1];
                                })},
      {"--frames-per-pose", integer(&o.stills.frames_per_pose, 1, 100)},
      {"--occluded-share", number(&o.stills.occluded_share, 0, 0.5)},
      {"--board-speed", number(&o.stills.board_speed_mps, 0, 3)},
      {"--duration", number(&o.trajectory.duration_s, 0.1, 3600)},
      {"--rate", number(&o.trajectory.rate_hz, 0.1, 50)},
      {"--frames", integer(&frames, 1, 100000)},
      {"--boards", integer(&o.workshop.num_boards, 1, 12)},
      {"--board-size", list(1, 2,
                            [&](auto& n) {
                              o.workshop.board_width_m = n[0];
                              o.workshop.board_height_m = n.size() > 1 ? n[1] : n[0];
                            })},
      {"--tag-size", number(&o.workshop.tag_size_m, 0.01, 5)},
      {"--tag-family", text(&o.workshop.tag_family)},
      {"--tag-ids", list(1, 12, [&](auto& n) { o.workshop.tag_ids.assign(n.begin(), n.end()); })},
      {"--board-scales",
       list(1, 12, [&](auto& n) { o.workshop.board_scales.assign(n.begin(), n.end()); })},
      {"--board-bows",
       list(1, 12, [&](auto& n) { o.workshop.board_bows_m.assign(n.begin(), n.end()); })},
      {"--checkerboard", list(4, 4,
                              [&](auto& n) {
                                o.workshop.checkerboard_board = static_cast<int>(n[0]);
                                o.workshop.checker_inner_rows = static_cast<int>(n[1]);
                                o.workshop.checker_inner_cols = static_cast<int>(n[2]);
                                o.workshop.checker_square_m = n[3];
                              })},
      {"--layout", text(&o.workshop.layout)},
      {"--board-spacing", number(&o.workshop.board_spacing_m, 0.1, 20)},
      {"--range-noise", number(&o.lidar_noise.range_sigma_m, 0, 0.5)},
      {"--angular-jitter", number(&o.lidar_noise.angular_jitter_deg, 0, 1)},
      {"--dropout", number(&o.lidar_noise.dropout_probability, 0, 0.99)},
      {"--beam-divergence", number(&o.lidar_noise.beam_divergence_mrad, 0, 20)},
      {"--range-bias", number(&o.lidar_noise.range_bias_m, -1, 1)},
      {"--camera-delay-us", integer(&o.camera_delay_us, -1e6, 1e6)},
      {"--camera-readout-us", integer(&o.camera_readout_us, 0, 200000)},
      {"--width", integer(&o.camera.width, 16, 16384)},
      {"--height", integer(&o.camera.height, 16, 16384)},
      {"--fx", number(&o.camera.fx, 1, 1e5)},
      {"--fy", number(&o.camera.fy, 1, 1e5)},
      {"--cx",
       [&](const std::string& v) {
         cx_set = true;
         return number(&o.camera.cx, 0, 16384)(v);
       }},
      {"--cy",
       [&](const std::string& v) {
         cy_set = true;
         return number(&o.camera.cy, 0, 16384)(v);
       }},
      {"--distortion", list(5, 5,
                            [&](auto& n) {
                              o.camera.k1 = n[0];
                              o.camera.k2 = n[1];
                              o.camera.p1 = n[2];
                              o.camera.p2 = n[3];
                              o.camera.k3 = n[4];
                            })},
      {"--blur", number(&o.imaging.blur_sigma_px, 0, 10)},
      {"--image-noise", number(&o.imaging.noise_sigma, 0, 50)},
      {"--exposure", list(2, 2,
                          [&](auto& n) {
                            o.imaging.exposure_min = n[0];
                            o.imaging.exposure_max = n[1];
                          })},
      {"--image-encoding", text(&o.image_encoding)},
      {"--jpeg-quality", integer(&o.jpeg_quality, 1, 100)},
      {"--lidar-mount", list(6, 6,
                             [&](auto& n) {
                               for (int i = 0; i < 6; ++i) o.lidar_mount[i] = n[i];
                             })},
      {"--camera-mount", list(6, 6,
                              [&](auto& n) {
                                for (int i = 0; i < 6; ++i) o.camera_mount[i] = n[i];
                              })},
      {"--prior-rot-deg", number(&o.prior_rot_deg, -10, 10)},
      {"--prior-rot-axis", list(3, 3,
                                [&](auto& n) {
                                  o.prior_rot_axis = {n[0], n[1], n[2]};
                                })},
      {"--prior-trans-m", number(&o.prior_trans_m, -0.5, 0.5)},
      {"--camera-id", text(&o.camera_id)},
      {"--lidar-id", text(&o.lidar_id)},
      {"--camera-serial", text(&o.camera_serial)},
      {"--lidar-serial", text(&o.lidar_serial)},
  };
  p.flags = {{"--quiet", [&] { quiet = true; }},
             {"--no-frames-csv", [&] { out.folder_without_times = true; }},
             {"--help", [&] { help = true; }},
             {"-h", [&] { help = true; }},
             {"--no-clutter", [&] { o.workshop.clutter = false; }},
             {"--no-walls", [&] { o.workshop.walls = false; }}};

  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i], value;
    bool has_inline = false;
    if (const auto eq = arg.find('='); arg.rfind("--", 0) == 0 && eq != std::string::npos) {
      value = arg.substr(eq + 1);
      arg = arg.substr(0, eq);
      has_inline = true;
    }
    if (auto f = p.flags.find(arg); f != p.flags.end() && !has_inline) {
      f->second();
      continue;
    }
    auto w = p.with_value.find(arg);
    if (w == p.with_value.end()) {
      std::cerr << "calibd-sim: unknown option '" << arg << "' (see --help)\n";
      return 2;
    }
    if (!has_inline) {
      if (i + 1 >= argc) {
        std::cerr << "calibd-sim: option " << arg << " needs a value (see --help)\n";
        return 2;
      }
      value = argv[++i];
    }
    if (!w->second(value)) {
      std::cerr << "calibd-sim: bad value '" << value << "' for " << arg << ": " << bad << "\n";
      return 2;
    }
  }
  if (help) {
    std::cout << kHelp;
    return 0;
  }
  if (!live.log_path.empty() || !live.url.empty()) {
    if (live.log_path.empty() || live.url.empty()) {
      std::cerr << "calibd-sim: --replay and --publish-url go together (see --help)\n";
      return 2;
    }
    calibd::sim::LivePublishSummary s;
    std::string error;
    if (!calibd::sim::PublishLive(live, &s, quiet ? nullptr : &std::cerr, &error)) {
      std::cerr << "calibd-sim: " << error << "\n";
      return 1;
    }
    if (!quiet)
      std::cout << "calibd-sim: published " << s.camera << " camera and " << s.lidar
                << " LiDAR frames, " << s.other << " other events (" << s.bytes / 1000000
                << " MB) in " << s.duration_s << " s; " << s.late
                << " events more than a frame period late (max " << s.max_lateness_ms << " ms)\n";
    return 0;
  }
  if (!cx_set) o.camera.cx = (o.camera.width - 1) / 2.0;
  if (!cy_set) o.camera.cy = (o.camera.height - 1) / 2.0;
  if (frames > 0) o.trajectory.duration_s = frames / o.trajectory.rate_hz;
  if (out.log_path.empty() && out.folder_path.empty()) {
    std::cerr << "calibd-sim: --out FILE or --folder DIR is required (see --help)\n";
    return 2;
  }
  std::string error;
  if (!o.IsValid(&error)) {
    std::cerr << "calibd-sim: " << error << "\n";
    return 2;
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
