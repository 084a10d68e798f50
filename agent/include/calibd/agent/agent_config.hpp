#pragma once
/// \file
/// The agent's one configuration file: sensors, intrinsics, boards, LiDAR model, buffer
/// sizes, collection limits and coverage gates, engine thresholds, store path and LCM URL.
///
/// Layout of the YAML file (every key documented in deploy/config/calibd.yaml):
/// - the calibration config at the top level (`camera`, `lidar`, `boards`, `prior`), read by
///   drivers/config_file.hpp, so a `calibd-sim --config-out` file is a valid agent config;
/// - an optional `agent:` section (the AgentConfig fields below, `store:` as a sub-section);
/// - an optional `engine:` section (the EngineConfig thresholds worth tuning on a vehicle).
/// Absent keys keep the defaults below. An unknown key inside `agent:` or `engine:` is an error:
/// a misspelt key would otherwise keep its default without a word. Validation names the bad key;
/// the agent then refuses to start and exits with code 2.

#include <array>
#include <string>

#include "calibd/agent/capture_guidance.hpp"
#include "calibd/agent/uds/uds_config.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/drivers/calibration_store.hpp"
#include "calibd/drivers/gpio_lines.hpp"
#include "calibd/drivers/isotp_channel.hpp"

namespace calibd {

/// Camera-to-board distance bins of the coverage gate, m: [0, 8.5), [8.5, 15), [15, 25), [25, inf).
/// The outer edges are the paper's Table II close (< 8.5 m) and far (> 25 m) subsets: close
/// boards fix the translation, far boards the rotation.
inline constexpr std::array<double, 3> kDistanceBinEdgesM{8.5, 15.0, 25.0};
inline constexpr int kDistanceBins = 4;
/// The image coverage gate counts board centres in a kImageGridSide x kImageGridSide grid (the
/// same grid as QualityFigures::image_coverage).
inline constexpr int kImageCells = kImageGridSide * kImageGridSide;

struct AgentConfig {
  CalibConfig calib;    ///< top-level keys: camera, lidar, boards, prior
  EngineConfig engine;  ///< `engine:` section (a subset of the fields is read from the file)

  // --- agent: connections and storage ---
  /// LCM provider URL, e.g. "udpm://239.255.76.67:7667?ttl=0" or "memq://" (tests); empty: LCM's
  /// default (the LCM_DEFAULT_URL environment variable, else UDP multicast on the local host).
  std::string lcm_url;
  /// `agent.store`: where the current, reference and previous calibrations live.
  CalibrationStoreConfig store = {"/var/lib/calibd"};
  /// `agent.cache_dir`: what the agent computes at each start and may keep between starts (the
  /// LiDAR detector's reference descriptors, lidar-references.bin: most of its start-up work),
  /// e.g. systemd's CacheDirectory=. Taken only when it was built from the same config, LiDAR
  /// model and board sizes and a sample of it built again agrees; otherwise built and rewritten.
  /// Losing it costs one slower start. Empty: nothing kept, built at every start.
  std::string cache_dir;
  /// The reference descriptors' file in cache_dir.
  static constexpr const char* kReferenceCacheName = "lidar-references.bin";

  // --- agent: buffers, sized once at start-up (fixed memory) ---
  /// Frame pairs kept for the solve. The session buffer takes about max_frames x
  /// BoardsPerFrame() x max_points_per_board x 16 bytes (see SessionBufferBytes()). A longer
  /// session is thinned to fit (core/session_thinning.hpp): the memory stays fixed.
  int max_frames = 200;
  /// Camera boards and LiDAR board clusters kept per frame pair; 0: the configured boards + 4
  /// (room for LiDAR clusters that pass the board gates without being boards). Use
  /// BoardsPerFrame() for the effective value.
  int max_boards_per_frame = 0;
  /// LiDAR points kept per board cluster (a larger cluster is kept as an even subsample of this
  /// many points, counted in IntakeCounters::lidar_boards_subsampled). The simulated ot128 puts
  /// about 50 points on a 0.6 m board at 6 m: the default leaves room for close boards and
  /// denser sensors.
  int max_points_per_board = 4096;
  /// LiDAR points per sweep an intake slot holds (22 bytes each); a larger sweep is refused and
  /// counted as bad. A 128-ring spinning LiDAR at 0.2 deg gives about 230k points, twice that
  /// with dual returns.
  int max_points_per_sweep = 400000;
  /// Frame pairs waiting for or in detection (one camera and one LiDAR detection thread); when
  /// all are taken, the newest pair is dropped and counted (agent/frame_intake.hpp).
  int intake_queue_capacity = 4;
  /// Heap for the solve's scratch (Ceres' Jacobians and workspaces), MB, faulted in at start-up
  /// and kept (agent/heap_reserve.hpp), so the solve after the last frame does not page-fault;
  /// 0: glibc's default heap policy. A 200-pair solve touches about 27 MB.
  int solve_heap_mb = 32;

  // --- agent: collection (one session) ---
  /// Collection time limit, s, unless the request sets its own (calibration_request_t
  /// max_duration_ms). At the limit the session solves with what it has, or fails with
  /// `too_few_frames` / `too_few_boards`.
  double max_duration_s = 120.0;
  /// Collection ends once this many frame pairs with boards are recorded; more than max_frames
  /// keeps the store thinned to pairs spread over the whole session.
  int target_frames = CoverageGates{}.target_frames;
  /// Fewest frame pairs with boards a session solves with: fewer at the time limit fails the
  /// session; the coverage gates end collection only from this many on. At least
  /// engine.verdict.min_frames (the engine would reject fewer anyway).
  int min_frames = CoverageGates{}.min_frames;
  /// Coverage gate: boards seen in at least this many of the kDistanceBins distance bins.
  int min_distance_bins = CoverageGates{}.min_distance_bins;
  /// Coverage gate: board centres in at least this many of the kImageCells image cells.
  int min_image_cells = CoverageGates{}.min_image_cells;
  /// End collection as soon as both coverage gates are met (and min_frames are recorded),
  /// instead of waiting for target_frames or the time limit.
  bool stop_on_coverage = true;
  /// A camera frame pairs with a LiDAR sweep if its time lies within the sweep or at most this
  /// far outside it, ms.
  double pair_tolerance_ms = 20.0;

  // --- agent: results and reports ---
  /// Commit an `updated` result to the store without waiting for ACTION_COMMIT.
  bool auto_commit = false;
  double status_rate_hz = channels::kStatus.rate_hz;  ///< calibration_status_t while running
  double health_rate_hz = channels::kHealth.rate_hz;  ///< health_t, always
  /// Reported in health_t; empty: this build's version (see SoftwareVersion()).
  std::string software_version;

  // --- agent: workshop diagnostics, all off by default ---
  /// `agent.can`: UDS on ISO-TP and the cyclic status frame on a SocketCAN interface.
  bool can_enabled = false;
  IsoTpConfig isotp;                 ///< interface, ids, padding, BS/STmin, CAN FD
  uint32_t status_frame_id = 0x3C0;  ///< cyclic status frame (deploy/calibd.dbc), 1 Hz
  /// `agent.uds`: the diagnostic server (secret file, state directory, timings, ECU serial).
  uds::UdsConfig uds = DefaultUdsConfig();
  /// `agent.gpio`: interlock, start button and status lamp, each optional.
  GpioConfig gpio;

  static uds::UdsConfig DefaultUdsConfig() {
    uds::UdsConfig u;
    u.secret_file = "/etc/calibd/uds_secret";
    u.state_dir = "/var/lib/calibd/uds";
    return u;
  }

  /// max_boards_per_frame, or when it is 0 the configured boards + 4.
  int BoardsPerFrame() const;
  /// software_version, or when it is empty "calibd <this build's version>".
  std::string SoftwareVersion() const;
  /// Bytes of the session buffer (LiDAR points with their times dominate), for the start-up log
  /// and the memory gate of IsValid.
  double SessionBufferBytes() const;

  /// Checks every field once (the calibration config, agent and engine keys); on failure `error`
  /// names the key as written in the file, e.g. "agent.max_frames: must be in [10, 100000]
  /// (got 3)".
  bool IsValid(std::string* error) const;
};

/// Parses YAML text into `config` (absent keys: defaults) and validates it. On failure `config`
/// is untouched and `error` reads "<key>: <what is wrong>".
bool ParseAgentConfigYaml(const std::string& text, AgentConfig* config, std::string* error);

/// The `engine:` section of a config's YAML text over `engine` (absent keys keep its values), as
/// the agent reads it; calibd-calibrate reads the same section. False with `error` naming the
/// key ("engine.verdict.min_boards: ...").
bool ParseEngineConfigYaml(const std::string& text, EngineConfig* engine, std::string* error);

/// Loads, parses and validates `path`. On failure `error` starts with the path, then names the
/// key: "/etc/calibd/calibd.yaml: agent.max_frames: must be in [10, 100000] (got 3)".
bool LoadAgentConfig(const std::string& path, AgentConfig* config, std::string* error);

}  // namespace calibd
