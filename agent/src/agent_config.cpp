#include "calibd/agent/agent_config.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>
#include <utility>
#include <vector>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"

namespace calibd {

namespace {

// Validation limits that are not obvious from the key alone.
constexpr int kMaxBoardsPerFrame = 256;
constexpr double kMaxSessionBufferBytes = 2.0 * 1024 * 1024 * 1024;  // 2 GiB
constexpr double kBytesPerPoint = 16.0;  // Vector3f + float time (SessionObservations)
constexpr size_t kMaxVersionLength = 64;

// Shortest decimal text that reads back to the same double (0.15, not 0.14999999999999999).
std::string Num(double v) {
  for (int digits = 6; digits <= 17; ++digits) {
    std::ostringstream o;
    o << std::setprecision(digits) << v;
    if (std::stod(o.str()) == v) return o.str();
  }
  return std::to_string(v);
}

bool Fail(std::string* error, const std::string& key, const std::string& what) {
  if (error) *error = key + ": " + what;
  return false;
}

// "key: must be in [lo, hi] (got v)", with `why` appended when the bounds come from other keys.
bool IntIn(const std::string& key, int v, int lo, int hi, std::string* error,
           const std::string& why = "") {
  if (v >= lo && v <= hi) return true;
  return Fail(error, key,
              "must be in [" + std::to_string(lo) + ", " + std::to_string(hi) + "] (got " +
                  std::to_string(v) + ")" + (why.empty() ? "" : ": " + why));
}

// Closed interval [lo, hi]; NaN fails.
bool DoubleIn(const std::string& key, double v, double lo, double hi, std::string* error) {
  if (v >= lo && v <= hi) return true;
  return Fail(error, key, "must be in [" + Num(lo) + ", " + Num(hi) + "] (got " + Num(v) + ")");
}

// (0, hi]: quantities that must be positive; NaN fails.
bool PositiveUpTo(const std::string& key, double v, double hi, std::string* error,
                  const std::string& why = "") {
  if (v > 0.0 && v <= hi) return true;
  return Fail(
      error, key,
      "must be in (0, " + Num(hi) + "] (got " + Num(v) + ")" + (why.empty() ? "" : ": " + why));
}

// The diagnostics sections; each struct's own check names the field, prefixed here with its
// section.
bool DiagnosticsValid(const AgentConfig& c, std::string* error) {
  std::string why;
  if (!c.gpio.IsValid(&why)) {  // already names agent.gpio.<line>.<key>
    if (error) *error = why;
    return false;
  }
  if (!c.can_enabled) return true;
  if (!c.isotp.IsValid(&why)) {
    if (error) *error = "agent.can." + why;
    return false;
  }
  const uint32_t max_id = c.isotp.extended_ids ? 0x1FFFFFFFu : 0x7FFu;
  if (c.status_frame_id > max_id)
    return Fail(error, "agent.can.status_frame_id",
                "must fit " + std::string(c.isotp.extended_ids ? "29" : "11") + " bits (got " +
                    std::to_string(c.status_frame_id) + ")");
  for (const uint32_t id :
       {c.isotp.physical_request_id, c.isotp.physical_response_id, c.isotp.functional_request_id})
    if (id == c.status_frame_id)
      return Fail(error, "agent.can.status_frame_id", "must differ from the diagnostic ids");
  // The file gives these two in s and ms (UdsConfig holds us).
  if (c.uds.lockout_delay_us < 0 || c.uds.lockout_delay_us > 86400LL * 1000000)
    return Fail(error, "agent.uds.lockout_delay_s",
                "must be in [0, 86400] (got " +
                    Num(static_cast<double>(c.uds.lockout_delay_us) * 1e-6) + ")");
  if (c.uds.s3_us < 100000 || c.uds.s3_us > 60000000)
    return Fail(error, "agent.uds.s3_ms",
                "must be in [100, 60000] (got " + std::to_string(c.uds.s3_us / 1000) + ")");
  if (!c.uds.IsValid(&why)) {  // names uds.<field>
    if (error) *error = "agent." + why;
    return false;
  }
  return true;
}

bool AgentKeysValid(const AgentConfig& c, std::string* error) {
  std::string why;
  if (!c.lcm_url.empty() && c.lcm_url.find("://") == std::string::npos)
    return Fail(error, "agent.lcm_url",
                "must be empty (LCM's default) or a provider URL such as "
                "udpm://239.255.76.67:7667 (got '" +
                    c.lcm_url + "')");
  if (!c.store.IsValid(&why)) {  // why: "keep_previous: must be >= 0 (got -1)"
    if (error) *error = "agent.store." + why;
    return false;
  }
  // A daemon's working directory is not something to depend on.
  if (c.store.directory.front() != '/')
    return Fail(error, "agent.store.directory",
                "must be an absolute path (got '" + c.store.directory + "')");

  if (!c.cache_dir.empty() && c.cache_dir.front() != '/')
    return Fail(error, "agent.cache_dir",
                "must be empty (no cache) or an absolute path (got '" + c.cache_dir + "')");

  if (!IntIn("agent.max_frames", c.max_frames, 10, 100000, error)) return false;
  const int boards = static_cast<int>(c.calib.boards.size());
  if (c.max_boards_per_frame != 0 &&
      !IntIn("agent.max_boards_per_frame", c.max_boards_per_frame, boards, kMaxBoardsPerFrame,
             error, "at least the configured boards (or 0: boards + 4)"))
    return false;
  if (!IntIn("agent.max_points_per_board", c.max_points_per_board, 64, 65536, error)) return false;
  if (c.SessionBufferBytes() > kMaxSessionBufferBytes)
    return Fail(error, "agent.max_points_per_board",
                "the session buffer would take " + Num(std::round(c.SessionBufferBytes() / 1e6)) +
                    " MB (max_frames " + std::to_string(c.max_frames) + " x " +
                    std::to_string(c.BoardsPerFrame()) + " boards x " +
                    std::to_string(c.max_points_per_board) +
                    " points x 16 B), more than 2 GiB: lower one of them");
  if (!IntIn("agent.max_points_per_sweep", c.max_points_per_sweep, 1000, 4000000, error))
    return false;
  if (!IntIn("agent.intake_queue_capacity", c.intake_queue_capacity, 1, 64, error)) return false;
  if (!IntIn("agent.solve_heap_mb", c.solve_heap_mb, 0, 1024, error)) return false;
  // Room for the pairs one drain can bring, twice over (session_thinning.hpp).
  if (c.max_frames < 2 * (c.intake_queue_capacity + 1))
    return Fail(error, "agent.max_frames",
                "must be at least 2 x (agent.intake_queue_capacity + 1) = " +
                    std::to_string(2 * (c.intake_queue_capacity + 1)) + " (got " +
                    std::to_string(c.max_frames) + ")");

  if (!PositiveUpTo("agent.max_duration_s", c.max_duration_s, 3600.0, error)) return false;
  if (!IntIn("agent.target_frames", c.target_frames, 1, 100000, error)) return false;
  if (!IntIn("agent.min_frames", c.min_frames, c.engine.verdict.min_frames, c.target_frames, error,
             "at least engine.verdict.min_frames, at most agent.target_frames"))
    return false;
  if (!IntIn("agent.min_distance_bins", c.min_distance_bins, 0, kDistanceBins, error)) return false;
  if (!IntIn("agent.min_image_cells", c.min_image_cells, 0, kImageCells, error)) return false;
  // At 10 Hz the next sweep starts 100 ms later: a wider window could pair the wrong sweep.
  if (!DoubleIn("agent.pair_tolerance_ms", c.pair_tolerance_ms, 0.0, 100.0, error)) return false;

  if (!PositiveUpTo("agent.status_rate_hz", c.status_rate_hz, 50.0, error)) return false;
  if (!PositiveUpTo("agent.health_rate_hz", c.health_rate_hz, 10.0, error)) return false;
  if (c.software_version.size() > kMaxVersionLength)
    return Fail(error, "agent.software_version",
                "must be at most " + std::to_string(kMaxVersionLength) + " characters (got " +
                    std::to_string(c.software_version.size()) + ")");
  for (const char ch : c.software_version) {
    if (ch < 0x20 || ch == 0x7f)
      return Fail(error, "agent.software_version", "must not hold control characters");
  }
  return DiagnosticsValid(c, error);
}

bool EngineKeysValid(const EngineConfig& e, std::string* error) {
  std::string why;
  if (!IntIn("engine.solver_threads", e.direct.threads, 1, 64, error)) return false;
  if (!IntIn("engine.stability_runs", e.stability_runs, 0, 32, error)) return false;
  if (!IntIn("engine.start_checks", e.start_checks, 0, 4, error)) return false;
  if (!IntIn("engine.max_solve_frames", e.max_solve_frames, 0, 100000, error)) return false;
  if (!DoubleIn("engine.grid.range_deg", e.grid.range_deg, 0.0, 30.0, error)) return false;
  if (!PositiveUpTo("engine.grid.step_deg", e.grid.step_deg, 10.0, error)) return false;
  // (2 range / step + 1)^3 candidates: 40 steps a side is already 531441 candidates.
  if (e.grid.range_deg / e.grid.step_deg > 40.0)
    return Fail(error, "engine.grid.step_deg",
                "range_deg / step_deg must be <= 40 (got " + Num(e.grid.range_deg) + " / " +
                    Num(e.grid.step_deg) + ")");

  const VerdictConfig& v = e.verdict;
  const std::string k = "engine.verdict.";
  if (!PositiveUpTo(k + "max_rotation_deg", v.max_rotation_deg, 180.0, error)) return false;
  if (!PositiveUpTo(k + "max_translation_m", v.max_translation_m, 10.0, error)) return false;
  if (!PositiveUpTo(k + "verify_rotation_deg", v.verify_rotation_deg, v.max_rotation_deg, error,
                    "at most max_rotation_deg"))
    return false;
  if (!PositiveUpTo(k + "verify_translation_m", v.verify_translation_m, v.max_translation_m, error,
                    "at most max_translation_m"))
    return false;
  if (!IntIn(k + "min_frames", v.min_frames, 1, 100000, error)) return false;
  if (!IntIn(k + "min_boards", v.min_boards, 1, 1000000, error)) return false;
  if (!DoubleIn(k + "max_rotation_sigma_deg", v.max_rotation_sigma_deg, 0.0, 10.0, error))
    return false;
  if (!DoubleIn(k + "max_translation_sigma_m", v.max_translation_sigma_m, 0.0, 1.0, error))
    return false;
  if (!DoubleIn(k + "min_plane_conditioning", v.min_plane_conditioning, 0.0, 1.0, error))
    return false;
  if (!PositiveUpTo(k + "max_rotation_spread_deg", v.max_rotation_spread_deg, 10.0, error))
    return false;
  if (!PositiveUpTo(k + "max_translation_spread_m", v.max_translation_spread_m, 1.0, error))
    return false;
  if (!PositiveUpTo(k + "max_start_rotation_deg", v.max_start_rotation_deg, 10.0, error))
    return false;
  if (!PositiveUpTo(k + "max_start_translation_m", v.max_start_translation_m, 1.0, error))
    return false;
  if (!PositiveUpTo(k + "max_camera_scale_error", v.max_camera_scale_error, 1.0, error))
    return false;
  if (!PositiveUpTo(k + "max_lidar_range_offset_m", v.max_lidar_range_offset_m, 1.0, error))
    return false;
  if (!PositiveUpTo(k + "max_time_offset_s", v.max_time_offset_s, 1.0, error)) return false;
  if (!PositiveUpTo(k + "max_reprojection_mean_deg", v.max_reprojection_mean_deg, 10.0, error))
    return false;
  if (!PositiveUpTo(k + "max_rotation_bound_deg", v.max_rotation_bound_deg, 180.0, error))
    return false;
  if (!PositiveUpTo(k + "max_translation_bound_m", v.max_translation_bound_m, 10.0, error))
    return false;
  if (!PositiveUpTo(k + "max_residual_rms_m", v.max_residual_rms_m, 1.0, error)) return false;

  // The fields the file does not expose keep the core's own checks (a config built in code).
  if (!e.grid.IsValid(&why)) return Fail(error, "engine", why);
  if (!e.motion.IsValid(&why)) return Fail(error, "engine.motion_window_s", why);
  if (!e.direct.IsValid(&why)) return Fail(error, "engine.direct", why);
  return true;
}

// Thrown only inside this file, to carry the failing key up to the parse entry point.
struct KeyError {
  std::string key, what;
};

// Edit distance, for "did you mean" on unknown keys (keys are short: O(n m) is nothing).
size_t EditDistance(const std::string& a, const std::string& b) {
  std::vector<size_t> row(b.size() + 1);
  for (size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (size_t i = 1; i <= a.size(); ++i) {
    size_t diagonal = row[0];
    row[0] = i;
    for (size_t j = 1; j <= b.size(); ++j) {
      const size_t above = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diagonal + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diagonal = above;
    }
  }
  return row[b.size()];
}

std::string Describe(const YAML::Node& n) {
  if (n.IsScalar()) return "'" + n.Scalar() + "'";
  if (n.IsSequence()) return "a list";
  if (n.IsMap()) return "a mapping";
  return "nothing";
}

bool Decode(const YAML::Node& n, std::string* value) {
  if (n.IsNull()) {  // `key:` with nothing after it: the empty string, not "null"
    value->clear();
    return true;
  }
  if (!n.IsScalar()) return false;
  *value = n.Scalar();
  return true;
}

template <typename T>
bool Decode(const YAML::Node& n, T* value) {
  try {
    *value = n.as<T>();
    return true;
  } catch (const YAML::Exception&) {
    return false;
  }
}

template <typename T>
const char* Expected();
template <>
const char* Expected<int>() {
  return "an integer";
}
template <>
const char* Expected<int64_t>() {
  return "an integer";
}
template <>
const char* Expected<double>() {
  return "a number";
}
template <>
const char* Expected<bool>() {
  return "true or false";
}
template <>
const char* Expected<std::string>() {
  return "a string";
}

// One mapping of the file. It remembers the keys it was asked for, so that whatever else the
// mapping holds can be reported as unknown.
class Section {
 public:
  // An absent section arrives as yaml-cpp's invalid node, which throws on every query: it is
  // replaced by an empty one.
  Section(const YAML::Node& node, std::string key)
      : node_(node ? node : YAML::Node()), key_(std::move(key)) {
    if (node_ && !node_.IsNull() && !node_.IsMap()) throw KeyError{key_, "must be a mapping"};
  }

  /// Reads `name` into `value`; an absent key leaves `value` (its default) as it is.
  template <typename T>
  void Read(const char* name, T* value) {
    known_.emplace_back(name);
    if (!node_.IsMap()) return;
    const YAML::Node n = Lookup(name);
    if (!n) return;
    if (!Decode(n, value))
      throw KeyError{key_ + "." + name,
                     std::string("must be ") + Expected<T>() + " (got " + Describe(n) + ")"};
  }

  Section Child(const char* name) {
    known_.emplace_back(name);
    return Section(node_.IsMap() ? Lookup(name) : YAML::Node(), key_ + "." + name);
  }

  /// A key this version no longer reads: where the mapping has it, an error that says what
  /// replaced it (`instead`), rather than "unknown key" or a silent change of meaning.
  void Replaced(const char* name, const std::string& instead) {
    known_.emplace_back(name);
    if (node_.IsMap() && Lookup(name))
      throw KeyError{key_ + "." + name, "no longer read: " + instead};
  }

  /// Throws for the first key that no Read or Child asked for.
  void RejectUnknown() const {
    if (!node_.IsMap()) return;
    for (const auto& kv : node_) {
      const std::string name = kv.first.as<std::string>();
      if (std::find(known_.begin(), known_.end(), name) != known_.end()) continue;
      std::string what = "unknown key";
      for (const std::string& k : known_) {
        if (EditDistance(name, k) <= 2) {
          what += " (did you mean " + k + "?)";
          break;
        }
      }
      throw KeyError{key_ + "." + name, what};
    }
  }

 private:
  // The const operator[]: the mutable one may add the key to the mapping.
  YAML::Node Lookup(const char* name) const { return node_[name]; }

  YAML::Node node_;
  std::string key_;
  std::vector<std::string> known_;
};

// Reads an unsigned field through int (hex like 0x7E0 works); the range is checked by IsValid.
template <typename U>
void ReadUnsigned(Section* s, const char* name, U* value) {
  int64_t v = static_cast<int64_t>(*value);
  s->Read(name, &v);
  *value = static_cast<U>(v < 0 || v > static_cast<int64_t>(UINT32_MAX) ? UINT32_MAX : v);
}

void ParseGpioLine(Section* gpio, const char* name, GpioLineConfig* line) {
  Section l = gpio->Child(name);
  l.Read("enabled", &line->enabled);
  l.Read("chip", &line->chip);
  l.Read("line", &line->line);
  l.Read("active_low", &line->active_low);
  l.RejectUnknown();
}

// agent.can, agent.uds, agent.gpio.
void ParseDiagnostics(Section* s, AgentConfig* c) {
  Section can = s->Child("can");
  can.Read("enabled", &c->can_enabled);
  IsoTpConfig& t = c->isotp;
  can.Read("interface", &t.interface);
  ReadUnsigned(&can, "physical_request_id", &t.physical_request_id);
  ReadUnsigned(&can, "physical_response_id", &t.physical_response_id);
  ReadUnsigned(&can, "functional_request_id", &t.functional_request_id);
  can.Read("extended_ids", &t.extended_ids);
  can.Read("padding", &t.padding);
  ReadUnsigned(&can, "pad_byte", &t.pad_byte);
  ReadUnsigned(&can, "block_size", &t.block_size);
  ReadUnsigned(&can, "st_min", &t.st_min);
  can.Read("can_fd", &t.can_fd);
  ReadUnsigned(&can, "status_frame_id", &c->status_frame_id);
  can.RejectUnknown();

  Section uds = s->Child("uds");
  uds.Read("secret_file", &c->uds.secret_file);
  uds.Read("state_dir", &c->uds.state_dir);
  uds.Read("max_key_attempts", &c->uds.max_key_attempts);
  double lockout_s = static_cast<double>(c->uds.lockout_delay_us) * 1e-6;
  uds.Read("lockout_delay_s", &lockout_s);
  c->uds.lockout_delay_us = static_cast<int64_t>(std::llround(lockout_s * 1e6));
  int s3_ms = static_cast<int>(c->uds.s3_us / 1000);
  uds.Read("s3_ms", &s3_ms);
  c->uds.s3_us = int64_t{s3_ms} * 1000;
  uds.Read("p2_ms", &c->uds.p2_ms);
  uds.Read("p2_star_ms", &c->uds.p2_star_ms);
  uds.Read("ecu_serial", &c->uds.ecu_serial);
  uds.RejectUnknown();

  Section gpio = s->Child("gpio");
  ParseGpioLine(&gpio, "interlock", &c->gpio.interlock);
  ParseGpioLine(&gpio, "start_button", &c->gpio.start_button);
  ParseGpioLine(&gpio, "status_lamp", &c->gpio.status_lamp);
  gpio.Read("start_button_debounce_ms", &c->gpio.start_button_debounce_ms);
  gpio.RejectUnknown();
}

void ParseAgentSection(const YAML::Node& node, AgentConfig* c) {
  Section s(node, "agent");
  s.Read("lcm_url", &c->lcm_url);
  Section store = s.Child("store");
  store.Read("directory", &c->store.directory);
  store.Read("keep_previous", &c->store.keep_previous);
  store.RejectUnknown();
  s.Read("cache_dir", &c->cache_dir);
  s.Read("max_frames", &c->max_frames);
  s.Read("max_boards_per_frame", &c->max_boards_per_frame);
  s.Read("max_points_per_board", &c->max_points_per_board);
  s.Read("max_points_per_sweep", &c->max_points_per_sweep);
  s.Read("intake_queue_capacity", &c->intake_queue_capacity);
  s.Read("solve_heap_mb", &c->solve_heap_mb);
  s.Read("max_duration_s", &c->max_duration_s);
  s.Read("target_frames", &c->target_frames);
  s.Read("min_frames", &c->min_frames);
  s.Read("min_distance_bins", &c->min_distance_bins);
  s.Read("min_image_cells", &c->min_image_cells);
  s.Read("stop_on_coverage", &c->stop_on_coverage);
  s.Read("pair_tolerance_ms", &c->pair_tolerance_ms);
  s.Read("auto_commit", &c->auto_commit);
  s.Read("status_rate_hz", &c->status_rate_hz);
  s.Read("health_rate_hz", &c->health_rate_hz);
  s.Read("software_version", &c->software_version);
  ParseDiagnostics(&s, c);
  s.RejectUnknown();
}

void ParseEngineSection(const YAML::Node& node, EngineConfig* e) {
  Section s(node, "engine");
  std::string method = e->method == EngineConfig::Method::kIndirect ? "indirect" : "direct";
  s.Read("method", &method);
  if (method == "direct") {
    e->method = EngineConfig::Method::kDirect;
  } else if (method == "indirect") {
    e->method = EngineConfig::Method::kIndirect;
  } else {
    throw KeyError{"engine.method", "must be direct or indirect (got '" + method + "')"};
  }
  // Named like calibd-calibrate's --motion-compensation and --board-pose-refinement.
  s.Read("motion_compensation", &e->motion.enabled);
  s.Read("motion_window_s", &e->motion.window_s);
  s.Read("board_pose_refinement", &e->direct.refine_board_poses);
  s.Read("solver_threads", &e->direct.threads);
  s.Read("stability_runs", &e->stability_runs);
  s.Read("start_checks", &e->start_checks);
  s.Read("max_solve_frames", &e->max_solve_frames);
  Section grid = s.Child("grid");
  grid.Read("range_deg", &e->grid.range_deg);
  grid.Read("step_deg", &e->grid.step_deg);
  grid.RejectUnknown();
  Section v = s.Child("verdict");
  v.Read("verify_rotation_deg", &e->verdict.verify_rotation_deg);
  v.Read("verify_translation_m", &e->verdict.verify_translation_m);
  v.Read("max_rotation_deg", &e->verdict.max_rotation_deg);
  v.Read("max_translation_m", &e->verdict.max_translation_m);
  v.Read("min_frames", &e->verdict.min_frames);
  v.Read("min_boards", &e->verdict.min_boards);
  v.Read("max_rotation_sigma_deg", &e->verdict.max_rotation_sigma_deg);
  v.Read("max_translation_sigma_m", &e->verdict.max_translation_sigma_m);
  v.Read("min_plane_conditioning", &e->verdict.min_plane_conditioning);
  v.Read("max_rotation_spread_deg", &e->verdict.max_rotation_spread_deg);
  v.Read("max_translation_spread_m", &e->verdict.max_translation_spread_m);
  v.Read("max_start_rotation_deg", &e->verdict.max_start_rotation_deg);
  v.Read("max_start_translation_m", &e->verdict.max_start_translation_m);
  v.Read("max_camera_scale_error", &e->verdict.max_camera_scale_error);
  v.Read("max_lidar_range_offset_m", &e->verdict.max_lidar_range_offset_m);
  v.Read("max_time_offset_s", &e->verdict.max_time_offset_s);
  v.Read("max_reprojection_mean_deg", &e->verdict.max_reprojection_mean_deg);
  v.Replaced("max_reprojection_mean_px",
             "the reprojection gate is an angle now, max_reprojection_mean_deg (0.14 deg: the "
             "8 px it was at fx = 3325 px; px = deg / 57.3 x fx)");
  v.Read("max_residual_rms_m", &e->verdict.max_residual_rms_m);
  v.Read("max_rotation_bound_deg", &e->verdict.max_rotation_bound_deg);
  v.Read("max_translation_bound_m", &e->verdict.max_translation_bound_m);
  v.RejectUnknown();
  s.RejectUnknown();
}

}  // namespace

int AgentConfig::BoardsPerFrame() const {
  return max_boards_per_frame > 0 ? max_boards_per_frame
                                  : static_cast<int>(calib.boards.size()) + 4;
}

std::string AgentConfig::SoftwareVersion() const {
  return software_version.empty() ? std::string("calibd ") + CALIBD_VERSION : software_version;
}

double AgentConfig::SessionBufferBytes() const {
  return static_cast<double>(max_frames) * static_cast<double>(BoardsPerFrame()) *
         static_cast<double>(max_points_per_board) * kBytesPerPoint;
}

bool AgentConfig::IsValid(std::string* error) const {
  return calib.IsValid(error) && AgentKeysValid(*this, error) && EngineKeysValid(engine, error);
}

bool ParseEngineConfigYaml(const std::string& text, EngineConfig* engine, std::string* error) {
  EngineConfig e = *engine;
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) return Fail(error, "<root>", "must be a mapping");
    ParseEngineSection(root["engine"], &e);
  } catch (const KeyError& k) {
    return Fail(error, k.key, k.what);
  } catch (const YAML::Exception& x) {
    if (error) *error = std::string("YAML syntax: ") + x.what();
    return false;
  }
  if (!EngineKeysValid(e, error)) return false;
  *engine = e;
  return true;
}

bool ParseAgentConfigYaml(const std::string& text, AgentConfig* config, std::string* error) {
  AgentConfig c;
  try {
    const YAML::Node root = YAML::Load(text);
    if (!root.IsMap()) return Fail(error, "<root>", "must be a mapping");
    // The calibration keys go through the calibration config's own parser, told of the agent's
    // sections.
    ConfigParseOptions options;
    options.other_sections = {"agent", "engine"};
    if (!ParseConfigYaml(text, &c.calib, error, options)) return false;
    ParseAgentSection(root["agent"], &c);
    ParseEngineSection(root["engine"], &c.engine);
  } catch (const KeyError& e) {
    return Fail(error, e.key, e.what);
  } catch (const YAML::Exception& e) {
    if (error) *error = std::string("YAML syntax: ") + e.what();
    return false;
  }
  if (!c.IsValid(error)) return false;
  *config = std::move(c);
  return true;
}

bool LoadAgentConfig(const std::string& path, AgentConfig* config, std::string* error) {
  return LoadTextFile(path, &ParseAgentConfigYaml, config, error);
}

}  // namespace calibd
