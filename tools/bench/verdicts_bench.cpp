#include "verdicts_bench.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <functional>
#include <map>
#include <memory>
#include <nlohmann/json.hpp>
#include <optional>
#include <random>

#include "calib_experiments.hpp"
#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/agent/session_recorder.hpp"
#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/solve/grid_search.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "quality_json.hpp"
#include "recordings_bench.hpp"
#include "seed_kind.hpp"

namespace calibd::bench {

namespace {

constexpr const char* kLidars[] = {"ot128",  "m1",     "falcon", "vlp16",
                                   "vlp32c", "os1-64", "avia",   "mid360"};

/// How much of its round's clean session (fault "none") a session's recording shares. A fault
/// that changes only the config, the stamps or the order of the pairs detects on the clean
/// session's pairs (kRecording); one that changes only the LiDAR's noise sweeps again beside its
/// images (kImages); one that changes only the camera renders again beside its sweeps (kSweeps).
/// Those sessions take the clean one's scene, trajectory and prior (its sim::SessionOptions);
/// the others simulate their own.
enum class Shares { kNothing, kImages, kSweeps, kRecording };

/// One session of the campaign: what is simulated, and what the recording and config say.
struct Session {
  int index = 0;
  std::string fault = "none";
  std::string magnitude;  ///< the fault's drawn size, in words (for the JSON)
  sim::SessionOptions sim;
  /// Applied to the simulator's UserConfig() (the user's config with a wrong figure).
  std::function<void(CalibConfig*)> edit_config;
  RecordingFaults recording;
  /// The LiDAR model the user configured (detector and range image); empty: the true one.
  std::string config_lidar;
  /// The frame pairs as the calibration receives them: as recorded, in a shuffled order (times
  /// intact), or each twice.
  enum class FrameOrder { kRecorded, kShuffled, kDuplicated } frame_order = FrameOrder::kRecorded;
  uint64_t order_seed = 0;
  int drive_frames = 0;  ///< frame pairs of this campaign's drives (quick or full)
  bool quick = false;
  Shares shares = Shares::kNothing;
};

using Rng = std::mt19937_64;

/// Quick sessions: the agent's collection ends at this many frame pairs with boards (its target
/// is 200, its minimum 50), and drives are this many pairs long.
constexpr int kQuickTargetFrames = 80;

/// How far `wrong` puts the image corner's ray from where `truth` does, px.
double CornerDisplacementPx(const CameraIntrinsics& truth, const CameraIntrinsics& wrong) {
  const CameraModel t(truth), w(wrong);
  Eigen::Vector2d xy, uv;
  if (!t.Unproject(Eigen::Vector2d(0.0, 0.0), &xy) ||
      !w.Project(Eigen::Vector3d(xy.x(), xy.y(), 1.0), &uv, 1e6))
    return std::numeric_limits<double>::infinity();
  return uv.norm();
}

double Draw(Rng* rng, double lo, double hi) {
  return std::uniform_real_distribution<double>(lo, hi)(*rng);
}
double Sign(Rng* rng) { return (*rng)() & 1u ? 1.0 : -1.0; }
std::string Num(double v, int decimals) { return FixedDecimal(v, decimals); }

/// Still poses at 1.5-8 m of 0.9 m boards (0.702 m tags), a new one every 2 s for as long as the
/// agent may collect (its time limit; RunSession stops where the agent's session machine does);
/// a few sweeps a pose, as the sensors keep sending while a pose stands.
void UseStillPoses(Session* s) {
  sim::SessionOptions& o = s->sim;
  o.trajectory.mode = "stills";
  o.trajectory.rate_hz = 0.5;
  o.trajectory.duration_s =
      static_cast<double>(SessionConfigFrom(AgentConfig{}).max_duration_us) * 1e-6;
  o.stills.frames_per_pose = s->quick ? 6 : 10;
  o.workshop.board_width_m = o.workshop.board_height_m = 0.9;
  o.workshop.tag_size_m = 0.702;
  o.stills.min_distance_m = 1.5;
  o.stills.max_distance_m = 8.0;
}

/// A frame pair every other sweep of a 10 Hz LiDAR: 2.5 m/s on average (quick), 1.25 m/s (full).
constexpr double kDrivePairRateHz = 5.0;

/// A drive past the boards at 4-14 m and back (the 1920 px camera sees a 0.6 m board's tag
/// there), drive_frames pairs at `rate_hz`.
void UseDrive(Session* s, double rate_hz) {
  sim::TrajectoryOptions& t = s->sim.trajectory;
  t.mode = "drive";
  t.min_distance_m = 4.0;
  t.max_distance_m = 14.0;
  t.rate_hz = rate_hz;
  t.duration_s = s->drive_frames / t.rate_hz;
}

/// A drive in any round: a still-pose round's boards (one of 0.9 m) become a drive's (at least
/// two of 0.6 m; one board along a straight drive leaves its plane's rotation unobservable).
void UseDriveInAnyRound(Session* s, double rate_hz) {
  UseDrive(s, rate_hz);
  s->sim.workshop.num_boards = std::max(2, s->sim.workshop.num_boards);
  s->sim.workshop.board_width_m = s->sim.workshop.board_height_m = 0.6;
  s->sim.workshop.tag_size_m = 0.48;
}

/// A draw in +-[lo, hi], either sign. The sign is drawn first, as GCC evaluated
/// `Sign(rng) * Draw(rng, ...)` (whose operands are unsequenced): the sessions stay those the
/// campaign's figures were measured on, with any compiler.
double SignedDraw(Rng* rng, double lo, double hi) {
  const double sign = Sign(rng);
  return sign * Draw(rng, lo, hi);
}

/// A factor 1 +- [lo, hi] (either sign), written as the session's magnitude in %.
double DrawFactor(Rng* rng, double lo, double hi, Session* s) {
  const double f = 1.0 + SignedDraw(rng, lo, hi);
  s->magnitude = Num((f - 1.0) * 100.0, 2) + " %";
  return f;
}

/// The catalogue: each fault draws its magnitude and changes the session.
struct Fault {
  const char* name;
  const char* what;
  void (*apply)(Rng* rng, Session* s);
  /// What the fault leaves of its round's clean recording (Session::shares).
  Shares shares = Shares::kNothing;
};

constexpr Fault kFaults[] = {
    {"none", "clean session", [](Rng*, Session*) {}, Shares::kRecording},
    {"camera_delay_stamped",
     "the camera exposes 0-100 ms after its trigger; its stamps say the trigger time",
     [](Rng* rng, Session* s) {
       const int64_t delay = std::llround(Draw(rng, 0.0, 100e3));
       s->sim.camera_delay_us = delay;
       s->recording.camera_stamp_shift_us = -delay;
       s->magnitude = Num(static_cast<double>(delay) * 1e-3, 1) + " ms";
     },
     Shares::kSweeps},
    {"camera_delay_no_times",
     "the camera exposes 0-100 ms after its trigger; pairs carry no capture times",
     [](Rng* rng, Session* s) {
       const int64_t delay = std::llround(Draw(rng, 0.0, 100e3));
       s->sim.camera_delay_us = delay;
       s->recording.no_times = true;
       s->magnitude = Num(static_cast<double>(delay) * 1e-3, 1) + " ms";
     },
     Shares::kSweeps},
    {"board_size", "the config's board width and height 1-5 % off",
     [](Rng* rng, Session* s) {
       const double f = DrawFactor(rng, 0.01, 0.05, s);
       s->edit_config = [f](CalibConfig* c) {
         for (auto& b : c->boards) {
           b.width_m *= f;
           b.height_m *= f;
         }
       };
     },
     Shares::kRecording},
    {"tag_size", "the config's tag size 1-5 % off",
     [](Rng* rng, Session* s) {
       const double f = DrawFactor(rng, 0.01, 0.05, s);
       s->edit_config = [f](CalibConfig* c) {
         for (auto& b : c->boards) {
           b.tag_size_m *= f;
           b.checker_square_size_m *= f;
         }
       };
     },
     Shares::kRecording},
    {"focal_length", "the config's fx and fy 0.5-3 % off",
     [](Rng* rng, Session* s) {
       const double f = DrawFactor(rng, 0.005, 0.03, s);
       s->edit_config = [f](CalibConfig* c) {
         c->camera.fx *= f;
         c->camera.fy *= f;
       };
     },
     Shares::kRecording},
    {"principal_point", "the config's principal point 5-20 px off",
     [](Rng* rng, Session* s) {
       const double r = Draw(rng, 5.0, 20.0), a = Draw(rng, 0.0, 2.0 * M_PI);
       s->magnitude = Num(r, 1) + " px";
       s->edit_config = [r, a](CalibConfig* c) {
         c->camera.cx += r * std::cos(a);
         c->camera.cy += r * std::sin(a);
       };
     },
     Shares::kRecording},
    {"range_bias", "every LiDAR range 2-5 cm long or short",
     [](Rng* rng, Session* s) {
       const double sign = Sign(rng);
       s->sim.lidar_noise.range_bias_m = sign * Draw(rng, 0.02, 0.05);
       s->magnitude = Num(s->sim.lidar_noise.range_bias_m * 100.0, 1) + " cm";
     },
     Shares::kImages},
    {"tag_off_centre",
     "the config puts the tag 10-40 mm off the board's centre; it is printed centred",
     [](Rng* rng, Session* s) {
       const double r = Draw(rng, 0.01, 0.04), a = Draw(rng, 0.0, 2.0 * M_PI);
       s->magnitude = Num(r * 1e3, 1) + " mm";
       s->edit_config = [r, a](CalibConfig* c) {
         for (auto& b : c->boards) b.tag_offset_m = r * Eigen::Vector2d(std::cos(a), std::sin(a));
       };
     },
     Shares::kRecording},
    {"distortion", "the config's lens distortion is another lens's (k1 -0.3..0.1, k2 -0.1..0.2)",
     [](Rng* rng, Session* s) {
       const double k1 = Draw(rng, -0.3, 0.1), k2 = Draw(rng, -0.1, 0.2);
       CameraIntrinsics wrong = s->sim.camera;
       wrong.k1 = k1;
       wrong.k2 = k2;
       wrong.p1 = wrong.p2 = wrong.k3 = 0.0;
       s->magnitude = Num(CornerDisplacementPx(s->sim.camera, wrong), 1) + " px at the corner";
       s->edit_config = [wrong](CalibConfig* c) { c->camera = wrong; };
     },
     Shares::kRecording},
    {"frames_1s_apart",
     "driving, a frame pair a second, the camera 10-100 ms late (stamped at its trigger)",
     [](Rng* rng, Session* s) {
       const int64_t delay = std::llround(Draw(rng, 10e3, 100e3));
       UseDriveInAnyRound(s, 1.0);
       s->sim.camera_delay_us = delay;
       s->recording.camera_stamp_shift_us = -delay;
       s->magnitude = Num(static_cast<double>(delay) * 1e-3, 1) + " ms";
     }},
    {"clock_drift", "the camera's clock runs 200-3000 ppm fast or slow against the LiDAR's",
     [](Rng* rng, Session* s) {
       const double sign = Sign(rng);
       s->recording.camera_clock_drift_ppm = sign * Draw(rng, 200.0, 3000.0);
       s->magnitude = Num(s->recording.camera_clock_drift_ppm, 0) + " ppm";
     },
     Shares::kRecording},
    {"wrong_lidar_model", "the config names another LiDAR model than the one recorded",
     [](Rng* rng, Session* s) {
       const int n = static_cast<int>(std::size(kLidars));
       std::string other = s->sim.lidar_model;
       while (other == s->sim.lidar_model)
         other = kLidars[std::uniform_int_distribution<int>(0, n - 1)(*rng)];
       s->config_lidar = other;
       s->magnitude = other;
     },
     Shares::kRecording},
    {"frames_reordered", "the frame pairs arrive in a shuffled order (their times intact)",
     [](Rng* rng, Session* s) {
       s->frame_order = Session::FrameOrder::kShuffled;
       s->order_seed = (*rng)();
       s->magnitude = "shuffled";
     },
     Shares::kRecording},
    {"frames_duplicated", "every frame pair arrives twice",
     [](Rng*, Session* s) {
       s->frame_order = Session::FrameOrder::kDuplicated;
       s->magnitude = "x2";
     },
     Shares::kRecording},
    {"prior_far", "the prior 12-20 deg off (beyond the grid search's 10 deg)",
     [](Rng* rng, Session* s) {
       const double deg = Draw(rng, 12.0, 20.0);
       // z, y, x: the order in which GCC evaluated the constructor's arguments here before, so
       // that the campaign's sessions stay what they were on every compiler.
       const double z = Draw(rng, -1, 1), y = Draw(rng, -1, 1), x = Draw(rng, -1, 1);
       Eigen::Vector3d axis(x, y, z);
       axis.normalize();
       s->magnitude = Num(deg, 1) + " deg";
       s->edit_config = [deg, axis](CalibConfig* c) {
         c->prior_T_camera_lidar.linear() =
             c->prior_T_camera_lidar.linear() *
             Eigen::AngleAxisd(deg * M_PI / 180.0, axis).toRotationMatrix();
       };
     },
     Shares::kRecording},
    {"ring_elevation",
     "each laser of a ring LiDAR fires 0.05-0.2 deg above or below its table's elevation",
     [](Rng* rng, Session* s) {
       // Ring LiDARs only: a session drawn with another takes the next ring LiDAR in kLidars.
       const int n = static_cast<int>(std::size(kLidars));
       int k = static_cast<int>(
           std::find(std::begin(kLidars), std::end(kLidars), std::string(s->sim.lidar_model)) -
           std::begin(kLidars));
       LidarModel model;
       for (int tries = 0; tries < n; ++tries, k = (k + 1) % n) {
         LidarKind kind;
         LidarKindFromName(kLidars[k], &kind, nullptr);
         model = MakeLidarModel(kind);
         if (model.has_rings) break;
       }
       s->sim.lidar_model = kLidars[k];
       const double size = Draw(rng, 0.05, 0.2);
       std::vector<double>& errors = s->sim.lidar_noise.ring_elevation_error_deg;
       errors.resize(model.ring_elevation_deg.size());
       for (double& e : errors) e = size * SignedDraw(rng, 0.5, 1.0);
       s->magnitude = "up to " + Num(size, 3) + " deg";
     },
     Shares::kImages},
    {"ids_swapped",
     "two boards of different sizes (the second 60-85 % of the first); the config swaps their ids",
     [](Rng* rng, Session* s) {
       const double scale = Draw(rng, 0.6, 0.85);
       sim::WorkshopOptions& w = s->sim.workshop;
       w.num_boards = std::max(2, w.num_boards);
       w.board_scales.assign(static_cast<size_t>(w.num_boards), 1.0);
       w.board_scales[1] = scale;
       s->magnitude = Num(scale * 100.0, 0) + " %";
       s->edit_config = [](CalibConfig* c) {
         std::swap(c->boards[0].board_id, c->boards[1].board_id);
         std::swap(c->boards[0].tag_id, c->boards[1].tag_id);
       };
     }},
    {"occluded",
     "still poses, someone standing 0.4-0.8 m in front of every board hides 10-40 % of its width",
     [](Rng* rng, Session* s) {
       UseStillPoses(s);
       s->sim.stills.occluded_share = Draw(rng, 0.1, 0.4);
       s->magnitude = Num(s->sim.stills.occluded_share * 100.0, 0) + " %";
     }},
    {"warped_board",
     "every board bent 5-20 mm about its vertical centre line, towards or away from the sensors",
     [](Rng* rng, Session* s) {
       const double size = Draw(rng, 0.005, 0.02);
       std::vector<double>& bows = s->sim.workshop.board_bows_m;
       bows.resize(static_cast<size_t>(s->sim.workshop.num_boards));
       for (double& b : bows) b = size * SignedDraw(rng, 0.5, 1.0);
       s->magnitude = "up to " + Num(size * 1e3, 1) + " mm";
     }},
    {"boards_carried",
     "still poses whose boards are still carried at 0.2-1 m/s while their frames are taken; the "
     "camera exposes 10-50 ms after its stamps",
     [](Rng* rng, Session* s) {
       UseStillPoses(s);
       s->sim.stills.board_speed_mps = Draw(rng, 0.2, 1.0);
       const int64_t delay = std::llround(Draw(rng, 10e3, 50e3));
       s->sim.camera_delay_us = delay;
       s->recording.camera_stamp_shift_us = -delay;
       s->magnitude = Num(s->sim.stills.board_speed_mps, 2) + " m/s, " +
                      Num(static_cast<double>(delay) * 1e-3, 1) + " ms";
     }},
    {"rolling_shutter",
     "driving, a rolling-shutter camera (the config knows none) reads its rows out top to bottom "
     "over 10-40 ms, stamped at the first row",
     [](Rng* rng, Session* s) {
       UseDriveInAnyRound(s, kDrivePairRateHz);
       const int64_t readout = std::llround(Draw(rng, 10e3, 40e3));
       s->sim.camera_readout_us = readout;
       s->magnitude = Num(static_cast<double>(readout) * 1e-3, 1) + " ms readout";
     },
     Shares::kSweeps},
    {"boards_far",
     "driving out to 25-40 m, where the camera sees the tags at 13-21 px: their distances too "
     "loose for the translation",
     [](Rng* rng, Session* s) {
       UseDriveInAnyRound(s, kDrivePairRateHz);
       s->sim.trajectory.max_distance_m = Draw(rng, 25.0, 40.0);
       s->magnitude = "to " + Num(s->sim.trajectory.max_distance_m, 1) + " m";
     }},
};
constexpr int kNumFaults = static_cast<int>(std::size(kFaults));

/// The faults the catalogue had when the sessions' seeds were fixed.
constexpr int kSeedFaults = 18;
static_assert(kNumFaults >= kSeedFaults, "faults are appended, never removed");

/// A session's seed key: its index in a catalogue of kSeedFaults faults (round * 18 + fault);
/// faults appended since draw keys of their own beyond them, so that adding a fault leaves every
/// other fault's sessions as they were (`--only` picks them by index in the current catalogue).
int SeedKey(int round, int fault) {
  static_assert(kNumFaults < 1000, "keys of appended faults: 1000 a round");
  return fault < kSeedFaults ? round * kSeedFaults + fault : 1000000 + round * 1000 + fault;
}

// Session i: fault i mod F; over the rounds i / F, drives and stills alternate, then the LiDAR
// model and the number of boards cycle, so that every fault meets every model in both modes.
Session MakeSession(int i, unsigned long long seed, bool quick) {
  Session s;
  s.index = i;
  const Fault& fault = kFaults[i % kNumFaults];
  const int round = i / kNumFaults;
  const auto key = static_cast<unsigned long long>(SeedKey(round, i % kNumFaults));
  Rng rng(seed * 1000003ULL + key);
  const int lidars = static_cast<int>(std::size(kLidars));
  const bool stills = round % 2 == 1;
  sim::SessionOptions& o = s.sim;
  o.seed = seed * 7919ULL + key;
  o.lidar_model = kLidars[(round / 2) % lidars];
  o.camera = ScenarioCamera(false);
  o.imaging.num_threads = 1;
  // Still poses of 1-3 boards; drives past 2-3 (one board along a straight drive leaves its
  // plane's rotation unobservable).
  const int variant = (round / (2 * lidars)) % 3;
  o.workshop.num_boards = stills ? 1 + variant : 2 + variant % 2;
  o.prior_rot_deg = Draw(&rng, 2.0, 8.0);
  o.prior_trans_m = Draw(&rng, 0.03, 0.15);
  // As long as the agent collects (CoverageGates: it solves from min_frames pairs with boards
  // and stops at target_frames): quick sessions just above the minimum, full ones at the target.
  s.quick = quick;
  s.drive_frames = quick ? kQuickTargetFrames : CoverageGates{}.target_frames;
  if (stills)
    UseStillPoses(&s);
  else
    UseDrive(&s, kDrivePairRateHz);
  s.fault = fault.name;
  if (fault.shares != Shares::kNothing && &fault != &kFaults[0]) {
    // The round's clean session's scene, trajectory and prior (its draws above are unused).
    o = MakeSession(round * kNumFaults, seed, quick).sim;
    const sim::SessionOptions clean = o;
    fault.apply(&rng, &s);
    // A fault that changes the LiDAR (ring_elevation in a round without rings) or the mode (a
    // rolling shutter in a still-pose round) changes the scene: simulated on its own.
    const bool same_scene = o.lidar_model == clean.lidar_model &&
                            o.trajectory.mode == clean.trajectory.mode &&
                            o.workshop.num_boards == clean.workshop.num_boards &&
                            o.workshop.board_width_m == clean.workshop.board_width_m &&
                            o.workshop.tag_size_m == clean.workshop.tag_size_m;
    s.shares = same_scene ? fault.shares : Shares::kNothing;
    return s;
  }
  fault.apply(&rng, &s);
  s.shares = fault.shares;
  return s;
}

struct SessionResult {
  Session session;
  ScoredRun run;
  double seconds = 0.0, detect_seconds = 0.0;
  std::string error;           ///< the session could not be simulated
  std::string collection_end;  ///< what ended the agent's collection (CollectionEndName)
  bool accepted() const { return run.verdict == "updated" || run.verdict == "verified"; }
};

/// One session's recording and verdict: the agent's session machine ends the collection on the
/// pairs as recorded, then the engine solves. Its pairs come from its own simulation or from one
/// its round shares (Session::shares; RunSessions).
class CampaignSession {
 public:
  CampaignSession(const Session& s, SessionResult* out) : s_(s), out_(out) {
    out_->session = s_;
    lidar_name_ = s_.config_lidar.empty() ? s_.sim.lidar_model : s_.config_lidar;
    LidarKind kind;
    LidarKindFromName(lidar_name_, &kind, nullptr);
    model_ = MakeLidarModel(kind);
    // The agent's session machine decides when the collection ends, on the pairs as recorded:
    // at its target (quick sessions: kQuickTargetFrames), at the coverage gates, at its time
    // limit, or where the recording ends; short of min_frames or min_boards it fails.
    SessionConfig agent = SessionConfigFrom(AgentConfig{});
    if (s_.quick) agent.gates.target_frames = kQuickTargetFrames;
    agent.sensor_timeout_us = 0;  // a replay: the sensors' pace is the simulator's
    machine_.emplace(agent);
  }
  CampaignSession(const CampaignSession&) = delete;
  CampaignSession& operator=(const CampaignSession&) = delete;

  bool Init() {
    RecordingFaults faults = s_.recording;
    faults.edit_config = [this](CalibConfig* c) {
      if (s_.edit_config) s_.edit_config(c);
      c->lidar_model = lidar_name_;
    };
    std::string error;
    if (!recorder_.Init(
            s_.sim, &drive_, &error, LidarDetectorConfig{}, &model_, faults,
            [this](const SessionObservations& recorded, const sim::FrameTruth& truth) {
              return KeepGoing(recorded, truth);
            },
            /*lidar_detector_later=*/true)) {
      out_->error = error;
      return false;
    }
    return true;
  }
  DriveRecorder& recorder() { return recorder_; }

  /// The frames, the agent's machine and the engine; `simulation_s`: this session's share of
  /// the simulations its pairs came from.
  void Finish(double simulation_s) {
    const auto t0 = std::chrono::steady_clock::now();
    recorder_.Finish(simulation_s);
    ReorderFrames();
    SessionMachine& machine = *machine_;
    if (machine.state() == SessionState::kCollecting) machine.EndOfData(last_lidar_us_);
    out_->detect_seconds = drive_.detect_s;
    if (machine.state() != SessionState::kSolving) {
      // Short of the agent's minimum (too_few_frames, too_few_boards): no verdict to judge, the
      // session is counted apart (Tally::collecting).
      out_->run.verdict = "collecting";
      out_->run.reason = NameOf(machine.reason());
      out_->run.detail = "collection: " + machine.detail();
      out_->run.frames = drive_.observations.num_frames;
    } else {
      out_->collection_end = CollectionEndName(machine.collection_end());
      const RangeImage projection = SessionProjection(model_);
      EngineConfig engine;
      engine.direct.threads = 1;
      out_->run =
          RunEngine(drive_.config, drive_.observations, projection, engine, drive_.T_camera_lidar);
    }
    out_->seconds = drive_.detect_s + SecondsSince(t0);
  }

 private:
  bool KeepGoing(const SessionObservations& recorded, const sim::FrameTruth& truth) {
    SessionMachine& machine = *machine_;
    last_lidar_us_ = truth.lidar_utime;
    if (machine.state() == SessionState::kIdle) {
      StartRequest start;
      start.mode = s_.sim.trajectory.mode == "stills" ? SessionMode::kStatic : SessionMode::kMoving;
      machine.Start(start, truth.lidar_utime);
    }
    CountCollectionFigures(recorded, recorded.num_frames - 1, s_.sim.camera.width,
                           s_.sim.camera.height, &figures_);
    machine.FrameRecorded(figures_, truth.lidar_utime);
    return machine.state() == SessionState::kCollecting;
  }

  // The pairs as the calibration receives them (Session::frame_order).
  void ReorderFrames() {
    if (s_.frame_order == Session::FrameOrder::kRecorded) return;
    const SessionObservations& recorded = drive_.observations;
    std::vector<int> frames;
    for (int f = 0; f < recorded.num_frames; ++f)
      for (int copy = 0; copy < (s_.frame_order == Session::FrameOrder::kDuplicated ? 2 : 1);
           ++copy)
        frames.push_back(f);
    if (s_.frame_order == Session::FrameOrder::kShuffled)
      std::shuffle(frames.begin(), frames.end(), Rng(s_.order_seed));
    drive_.observations =
        SelectFrames(recorded, frames, std::vector<char>(recorded.camera.size(), 1),
                     std::vector<char>(recorded.lidar.size(), 1));
  }

  const Session s_;
  SessionResult* out_;
  std::string lidar_name_;  // the LiDAR model the config names
  LidarModel model_;
  std::optional<SessionMachine> machine_;
  CollectionFigures figures_;
  int64_t last_lidar_us_ = 0;
  DriveRecorder recorder_;
  RecordedDrive drive_;
};

/// What a session's LiDAR detector is built from: its model and the boards' sides (all it reads
/// of the boards).
std::string LidarDetectorKey(const CalibConfig& config) {
  std::string key = config.lidar_model;
  for (const BoardGeometry& b : config.boards)
    key += " " + ShortestDecimal(b.width_m) + "x" + ShortestDecimal(b.height_m);
  return key;
}

/// What a session's camera detector is built from: the intrinsics and the boards.
std::string CameraDetectorKey(const CalibConfig& config) {
  CalibConfig c;
  c.camera = config.camera;
  c.boards = config.boards;
  return ConfigToYaml(c);
}

/// Records and solves `sessions`, which share the recording of their round's clean session
/// (`clean`, simulated here) as Session::shares says: a session that shares the whole recording
/// detects on its pairs; one that shares the images sweeps again (same scene, same seed, its
/// LiDAR's noise), one that shares the sweeps renders again (its camera). A detector built from
/// the same inputs as an earlier session's, on the same frames, gives its output: it is copied
/// from that session's, which keeps detecting while a session copies it. Pairs are simulated
/// until every session's collection has ended.
void RunSessions(const sim::SessionOptions& clean, const std::vector<Session>& sessions,
                 const std::vector<SessionResult*>& out) {
  const size_t n = sessions.size();
  std::vector<std::unique_ptr<CampaignSession>> runs;
  std::vector<char> active(n, 0);
  for (size_t m = 0; m < n; ++m) {
    runs.push_back(std::make_unique<CampaignSession>(sessions[m], out[m]));
    active[m] = runs[m]->Init() ? 1 : 0;
  }
  // The shared frames come from a session that records the clean recording itself (a session
  // alone is its own); only a round whose every session changes the sweeps or the images needs
  // a simulator of its own (it detects nothing: its LiDAR detector is never built).
  DetectedSession own_base;
  DetectedSession* base = nullptr;
  for (size_t m = 0; m < n && !base; ++m)
    if (active[m] && (n == 1 || sessions[m].shares == Shares::kRecording))
      base = &runs[m]->recorder().session();
  if (!base) {
    std::string error;
    if (!own_base.Init(clean, &error, LidarDetectorConfig{}, nullptr, nullptr,
                       /*lidar_detector_later=*/true)) {
      for (SessionResult* r : out) r->error = "the round's clean session: " + error;
      return;
    }
    base = &own_base;
  }
  auto own_sweep = [&](size_t m) { return sessions[m].shares == Shares::kImages; };
  auto own_image = [&](size_t m) { return sessions[m].shares == Shares::kSweeps; };
  // Each session's detectors copy the first session's with the same key (itself: it detects).
  std::vector<size_t> lidar_from(n), camera_from(n);
  std::vector<std::string> lidar_keys(n), camera_keys(n);
  for (size_t m = 0; m < n; ++m) {
    const CalibConfig& config = runs[m]->recorder().session().user_config();
    const std::string own = "/" + std::to_string(m);
    lidar_keys[m] = LidarDetectorKey(config) + (own_sweep(m) ? own : "");
    camera_keys[m] = CameraDetectorKey(config) + (own_image(m) ? own : "");
    lidar_from[m] = camera_from[m] = m;
    for (size_t e = 0; e < m; ++e) {
      if (!active[e]) continue;
      if (lidar_from[m] == m && lidar_keys[e] == lidar_keys[m]) lidar_from[m] = e;
      if (camera_from[m] == m && camera_keys[e] == camera_keys[m]) camera_from[m] = e;
    }
  }
  // Only the LiDAR detectors that detect are built (their references: half a second of the two
  // cores each, 23 a round before).
  for (size_t m = 0; m < n; ++m) {
    std::string error;
    if (active[m] && lidar_from[m] == m &&
        !runs[m]->recorder().session().BuildLidarDetector(&error)) {
      out[m]->error = "LiDAR detector: " + error;
      active[m] = 0;
    }
  }
  // The sessions that detect the shared image search each AprilTag window of it once.
  TagSearchMemo shared_image_searches;
  for (size_t m = 0; m < n; ++m)
    if (active[m] && !own_image(m))
      runs[m]->recorder().session().UseTagSearchMemo(&shared_image_searches);
  std::vector<double> simulation_s(n, 0.0);
  // Each with a buffer of its own to render into: an image rendered into a cv::Mat that shares
  // its buffer with another frame's would overwrite that one.
  SimulatedFrame shared, own_sweep_frame, own_image_frame;
  const int frames = base->session().num_frames();
  for (int k = 0; k < frames; ++k) {
    // Detectors others copy from keep detecting while those sessions record.
    std::vector<char> lidar_needed(n, 0), camera_needed(n, 0);
    size_t recording = 0;
    for (size_t m = 0; m < n; ++m) {
      if (!active[m]) continue;
      ++recording;
      lidar_needed[lidar_from[m]] = camera_needed[camera_from[m]] = 1;
    }
    if (recording == 0) break;
    auto t0 = std::chrono::steady_clock::now();
    base->Simulate(k, true, &shared);
    shared_image_searches.Clear();  // searches of the last frame's image
    const double shared_s = SecondsSince(t0);
    for (size_t m = 0; m < n; ++m) {
      if (!active[m] && !lidar_needed[m] && !camera_needed[m]) continue;
      const SimulatedFrame* frame = &shared;
      if (own_sweep(m)) {
        t0 = std::chrono::steady_clock::now();
        runs[m]->recorder().session().Simulate(k, false, &own_sweep_frame);
        own_sweep_frame.image = shared.image;
        simulation_s[m] += SecondsSince(t0);
        frame = &own_sweep_frame;
      } else if (own_image(m)) {
        t0 = std::chrono::steady_clock::now();
        SimulatedFrame& own = own_image_frame;
        runs[m]->recorder().session().Simulate(k, true, &own, false);
        own.scan = shared.scan;
        for (size_t b = 0; b < own.truth.boards.size(); ++b)
          own.truth.boards[b].lidar_point_indices = shared.truth.boards[b].lidar_point_indices;
        simulation_s[m] += SecondsSince(t0);
        frame = &own;
      }
      DriveRecorder& recorder = runs[m]->recorder();
      if (!active[m]) {
        recorder.DetectOnly(*frame, lidar_needed[m] != 0, camera_needed[m] != 0);
        continue;
      }
      simulation_s[m] += shared_s / static_cast<double>(recording);
      const DriveRecorder* same_lidar =
          lidar_from[m] != m ? &runs[lidar_from[m]]->recorder() : nullptr;
      const DriveRecorder* same_camera =
          camera_from[m] != m ? &runs[camera_from[m]]->recorder() : nullptr;
      active[m] = recorder.Add(*frame, same_lidar, same_camera) ? 1 : 0;
    }
  }
  for (size_t m = 0; m < n; ++m)
    if (out[m]->error.empty()) runs[m]->Finish(simulation_s[m]);
}

/// Counts of one table row.
struct Tally {
  int sessions = 0, accepted_ok = 0, false_accepts = 0, false_rejects = 0, rejections = 0;
  int collecting = 0;  ///< short of the agent's minimum: no verdict (RunSession)
  /// Clean sessions refused whose result lay beyond the tolerance (counted in `rejections`): not
  /// sessions the agent would solve.
  int clean_beyond_tolerance = 0;
  /// Sessions solved (an estimate, accepted or not) and those whose true error lay inside the
  /// result's own predicted bound (QualityFigures::rotation_bound_deg, translation_bound_m).
  int solved = 0, inside_bound = 0;
  std::map<std::string, int> reasons;
  double worst_accepted_deg = 0.0, worst_accepted_m = 0.0;
};

}  // namespace

int VerdictSessionIndex(const std::string& fault, int round) {
  for (int f = 0; f < kNumFaults; ++f)
    if (fault == kFaults[f].name) return round * kNumFaults + f;
  return -1;
}

std::string VerdictFaultNames() {
  std::string out;
  for (const Fault& f : kFaults) out += (out.empty() ? "" : ", ") + std::string(f.name);
  return out;
}

bool IsVerdictFault(const std::string& name) { return VerdictSessionIndex(name, 0) >= 0; }

std::vector<int> VerdictSessionIndices(const VerdictsBenchOptions& o) {
  std::vector<int> indices = o.only;
  if (indices.empty())
    for (int i = 0; i < o.sessions; ++i) indices.push_back(i);
  if (o.faults.empty()) return indices;
  std::vector<int> kept;
  for (const int i : indices) {
    const std::string fault = kFaults[i % kNumFaults].name;
    if (std::find(o.faults.begin(), o.faults.end(), fault) != o.faults.end()) kept.push_back(i);
  }
  return kept;
}

bool RunVerdictsBench(const VerdictsBenchOptions& o, std::ostream& out, std::ostream* progress,
                      std::string* error) {
  // A false accept: beyond the accuracy a result must be known to (the error bound's gate).
  const VerdictConfig tolerance;
  const double max_deg = tolerance.max_rotation_bound_deg;
  const double max_m = tolerance.max_translation_bound_m;
  const std::vector<int> indices = VerdictSessionIndices(o);
  if (indices.empty()) {
    if (error) *error = "no session of the faults asked for among the sessions asked for";
    return false;
  }
  const int count = static_cast<int>(indices.size());
  std::vector<SessionResult> results(indices.size());
  // Tasks: the sessions of a round that share its clean recording together, each other session
  // alone; the largest first, so that the threads end together.
  std::vector<std::vector<size_t>> tasks;
  std::map<int, size_t> shared_task_of_round;
  for (size_t k = 0; k < indices.size(); ++k) {
    if (!o.share_recordings ||
        MakeSession(indices[k], o.seed, o.quick).shares == Shares::kNothing) {
      tasks.push_back({k});
      continue;
    }
    const auto [it, added] = shared_task_of_round.emplace(indices[k] / kNumFaults, tasks.size());
    if (added) tasks.emplace_back();
    tasks[it->second].push_back(k);
  }
  std::stable_sort(tasks.begin(), tasks.end(),
                   [](const auto& a, const auto& b) { return a.size() > b.size(); });
  const auto t0 = std::chrono::steady_clock::now();
  ParallelTasks(
      static_cast<int>(tasks.size()), o.threads,
      [&](int t) {
        std::vector<Session> sessions;
        std::vector<SessionResult*> task_results;
        for (size_t k : tasks[static_cast<size_t>(t)]) {
          sessions.push_back(MakeSession(indices[k], o.seed, o.quick));
          task_results.push_back(&results[k]);
        }
        // A session alone is its own clean recording, whole.
        if (sessions.size() == 1) sessions.front().shares = Shares::kNothing;
        const int round = sessions.front().index / kNumFaults;
        RunSessions(sessions.size() == 1 ? sessions.front().sim
                                         : MakeSession(round * kNumFaults, o.seed, o.quick).sim,
                    sessions, task_results);
      },
      progress, "calibd-bench verdicts (" + std::to_string(count) + " sessions)", "recordings", 10);

  std::map<std::string, Tally> by_fault;
  Tally all;
  nlohmann::json doc;
  doc["seed"] = o.seed;
  doc["seed_kind"] = SeedKind(o.seed);
  doc["quick"] = o.quick;
  doc["false_accept_rotation_deg"] = max_deg;
  doc["false_accept_translation_m"] = max_m;
  for (const SessionResult& r : results) {
    if (!r.error.empty()) {
      if (error)
        *error = "session " + std::to_string(r.session.index) + " (" + r.session.sim.lidar_model +
                 ", " + r.session.fault + "): " + r.error;
      return false;
    }
    const bool within = r.run.has_estimate && r.run.rotation_error_deg <= max_deg &&
                        r.run.translation_error_m <= max_m;
    const bool inside_bound = r.run.has_estimate &&
                              r.run.rotation_error_deg <= r.run.quality.rotation_bound_deg &&
                              r.run.translation_error_m <= r.run.quality.translation_bound_m;
    for (Tally* t : {&by_fault[r.session.fault], &all}) {
      ++t->sessions;
      if (r.run.has_estimate) {
        ++t->solved;
        t->inside_bound += inside_bound ? 1 : 0;
      }
      if (r.run.verdict == "collecting") {
        ++t->collecting;
      } else if (r.accepted()) {
        (within ? t->accepted_ok : t->false_accepts) += 1;
        t->worst_accepted_deg = std::max(t->worst_accepted_deg, r.run.rotation_error_deg);
        t->worst_accepted_m = std::max(t->worst_accepted_m, r.run.translation_error_m);
      } else {
        // A clean session refused whose result lay beyond the tolerance was refused rightly: its
        // scene could not pin the extrinsic down.
        const bool clean = r.session.fault == std::string("none");
        const bool rightly = !clean || (r.run.has_estimate && !within);
        (rightly ? t->rejections : t->false_rejects) += 1;
        if (clean && rightly) ++t->clean_beyond_tolerance;
        ++t->reasons[r.run.reason.empty() ? r.run.verdict : r.run.reason];
      }
    }
    nlohmann::json j;
    j["index"] = r.session.index;
    j["lidar"] = r.session.sim.lidar_model;
    j["mode"] = r.session.sim.trajectory.mode;
    j["boards"] = r.session.sim.workshop.num_boards;
    j["fault"] = r.session.fault;
    j["magnitude"] = r.session.magnitude;
    j["verdict"] = r.run.verdict;
    j["reason"] = r.run.reason;
    j["detail"] = r.run.detail;
    j["camera_boards"] = r.run.camera_boards;
    j["boards_used"] = r.run.boards_used;
    if (r.run.has_estimate) {
      j["rotation_error_deg"] = r.run.rotation_error_deg;
      j["translation_error_m"] = r.run.translation_error_m;
      const Eigen::Vector3d& t = r.run.translation_error_xyz_m;
      const Eigen::Vector3d& rpy = r.run.error_rpy_deg;
      j["translation_error_xyz_m"] = {t.x(), t.y(), t.z()};
      j["rotation_error_rpy_deg"] = {rpy.x(), rpy.y(), rpy.z()};
    }
    if (r.run.has_estimate) {
      const QualityFigures& q = r.run.quality;
      j["quality"] = QualityJson(q);
      j["quality"]["board_translation_change_m"] = r.run.board_translation_change_m;
    }
    j["collection_end"] = r.collection_end;
    j["frames"] = r.run.frames;
    j["false_accept"] = r.accepted() && !within;
    if (r.run.has_estimate) j["inside_bound"] = inside_bound;
    j["seconds"] = r.seconds;
    j["detect_seconds"] = r.detect_seconds;
    doc["sessions"].push_back(j);
  }

  out << "Fault campaign: " << count << " sessions (" << (o.quick ? "quick" : "full") << ", "
      << SeedLabel(o.seed) << "), LiDARs";
  for (const char* l : kLidars) out << " " << l;
  out << "; drives at 4-14 m and still poses at 1.5-8 m, 1-3 boards, a 1920 x 1200 camera.\n"
      << "A false accept is `updated` or `verified` with an error above " << Num(max_deg, 2)
      << " deg or " << Num(max_m * 100.0, 1)
      << " cm (the accuracy a result must be known to: engine.verdict.max_rotation_bound_deg, "
         "max_translation_bound_m); a false reject, a clean session refused whose result lay "
         "within it (a clean session refused with its result beyond it is refused rightly).\n\n"
      << "| fault | what | sessions | accepted within tolerance | false accepts | false rejects | "
         "refused rightly | short of the agent's minimum | worst accepted error | error inside "
         "its bound (solved) | reasons of the refusals |\n"
      << "|---|---|---|---|---|---|---|---|---|---|---|\n";
  auto row = [&](const std::string& name, const char* what, const Tally& t) {
    std::string reasons;
    for (const auto& [reason, n] : t.reasons)
      reasons += (reasons.empty() ? "" : ", ") + reason + " " + std::to_string(n);
    out << "| " << name << " | " << what << " | " << t.sessions << " | " << t.accepted_ok << " | "
        << t.false_accepts << " | " << t.false_rejects << " | " << t.rejections << " | "
        << t.collecting << " | " << Num(t.worst_accepted_deg, 3) << " deg / "
        << Num(t.worst_accepted_m * 100.0, 1) << " cm | " << t.inside_bound << " / " << t.solved
        << " | " << (reasons.empty() ? "-" : reasons) << " |\n";
  };
  for (const Fault& f : kFaults)
    if (by_fault.count(f.name)) row(f.name, f.what, by_fault[f.name]);
  row("**all**", "", all);
  // Judged: the clean sessions the agent would have solved (not short of its minimum, and a
  // result within the tolerance unless none was reached).
  const Tally& none = by_fault["none"];
  const double clean = none.sessions - none.collecting - none.clean_beyond_tolerance;
  out << "\nFalse accepts: " << all.false_accepts << " (target 0); " << all.collecting
      << " sessions short of the agent's minimum (not judged); false rejects: " << all.false_rejects
      << " of " << clean << " clean sessions the agent would solve ("
      << Num(clean > 0 ? 100.0 * all.false_rejects / clean : 0.0, 1) << " %, target <= 5 %); "
      << "the true error inside the result's own 99 % bound in " << all.inside_bound << " of "
      << all.solved << " solved sessions ("
      << Num(all.solved > 0 ? 100.0 * all.inside_bound / all.solved : 0.0, 1)
      << " %, target >= 99 %); " << Num(SecondsSince(t0) / 60.0, 1) << " min.\n";
  doc["false_accepts"] = all.false_accepts;
  doc["false_rejects"] = all.false_rejects;
  doc["short_of_the_agents_minimum"] = all.collecting;
  doc["solved"] = all.solved;
  doc["inside_bound"] = all.inside_bound;
  if (!o.json_path.empty() && !WriteFileAtomic(o.json_path, doc.dump(2) + "\n", error))
    return false;
  if (all.false_accepts > 0) {
    if (error) *error = std::to_string(all.false_accepts) + " false accepts (see the table)";
    return false;
  }
  return true;
}

}  // namespace calibd::bench
