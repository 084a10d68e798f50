#include "calibd/agent/agent_config.hpp"

#include <gtest/gtest.h>

#include <array>
#include <utility>
#include <vector>

#include <cstdlib>
#include <fstream>
#include <sstream>

#include "calibd/drivers/config_file.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

const std::string kDefaultConfigPath =
    std::string(CALIBD_SOURCE_DIR) + "/deploy/config/calibd.yaml";

std::string ReadText(const std::string& path) {
  std::ifstream in(path);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

void WriteText(const std::string& path, const std::string& text) { std::ofstream(path) << text; }

// Every agent and engine field equals the defaults in the headers.
void ExpectAgentAndEngineDefaults(const AgentConfig& c) {
  const AgentConfig d;
  EXPECT_EQ(c.lcm_url, d.lcm_url);
  EXPECT_EQ(c.store.directory, "/var/lib/calibd");
  EXPECT_EQ(c.store.keep_previous, d.store.keep_previous);
  EXPECT_EQ(c.max_frames, 200);
  EXPECT_EQ(c.max_boards_per_frame, 0);
  EXPECT_EQ(c.BoardsPerFrame(), static_cast<int>(c.calib.boards.size()) + 4);
  EXPECT_EQ(c.max_points_per_board, 4096);
  EXPECT_EQ(c.max_points_per_sweep, 400000);
  EXPECT_EQ(c.intake_queue_capacity, 4);
  EXPECT_EQ(c.solve_heap_mb, 32);
  EXPECT_EQ(c.max_duration_s, 120.0);
  EXPECT_EQ(c.target_frames, 200);
  EXPECT_EQ(c.min_frames, d.min_frames);
  EXPECT_EQ(c.min_distance_bins, d.min_distance_bins);
  EXPECT_EQ(c.min_image_cells, d.min_image_cells);
  EXPECT_EQ(c.stop_on_coverage, d.stop_on_coverage);
  EXPECT_EQ(c.pair_tolerance_ms, 20.0);
  EXPECT_FALSE(c.auto_commit);
  EXPECT_EQ(c.status_rate_hz, 2.0);
  EXPECT_EQ(c.health_rate_hz, 1.0);
  EXPECT_EQ(c.software_version, "");
  EXPECT_EQ(c.SoftwareVersion().rfind("calibd ", 0), 0u) << c.SoftwareVersion();

  const EngineConfig& e = c.engine;
  const EngineConfig de;
  EXPECT_EQ(e.method, EngineConfig::Method::kDirect);
  EXPECT_EQ(e.motion.enabled, de.motion.enabled);
  EXPECT_EQ(e.motion.window_s, de.motion.window_s);
  EXPECT_EQ(e.direct.refine_board_poses, de.direct.refine_board_poses);
  EXPECT_EQ(e.direct.threads, de.direct.threads);
  EXPECT_EQ(e.stability_runs, de.stability_runs);
  EXPECT_EQ(e.max_solve_frames, de.max_solve_frames);
  EXPECT_EQ(e.grid.range_deg, de.grid.range_deg);
  EXPECT_EQ(e.grid.step_deg, de.grid.step_deg);
  const VerdictConfig& v = e.verdict;
  const VerdictConfig& dv = de.verdict;
  EXPECT_EQ(v.verify_rotation_deg, dv.verify_rotation_deg);
  EXPECT_EQ(v.verify_translation_m, dv.verify_translation_m);
  EXPECT_EQ(v.max_rotation_deg, dv.max_rotation_deg);
  EXPECT_EQ(v.max_translation_m, dv.max_translation_m);
  EXPECT_EQ(v.min_frames, dv.min_frames);
  EXPECT_EQ(v.min_boards, dv.min_boards);
  EXPECT_EQ(v.max_rotation_sigma_deg, dv.max_rotation_sigma_deg);
  EXPECT_EQ(v.max_translation_sigma_m, dv.max_translation_sigma_m);
  EXPECT_EQ(v.min_plane_conditioning, dv.min_plane_conditioning);
  EXPECT_EQ(v.max_rotation_spread_deg, dv.max_rotation_spread_deg);
  EXPECT_EQ(v.max_translation_spread_m, dv.max_translation_spread_m);
  EXPECT_EQ(v.max_reprojection_mean_deg, dv.max_reprojection_mean_deg);
  EXPECT_EQ(v.max_residual_rms_m, dv.max_residual_rms_m);
}

TEST(AgentConfigTest, DocumentedDefaultFileLoadsWithTheDocumentedValues) {
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(LoadAgentConfig(kDefaultConfigPath, &c, &error)) << error;
  ExpectAgentAndEngineDefaults(c);
  EXPECT_EQ(c.cache_dir, "/var/cache/calibd");  // calibd.service's CacheDirectory=
  EXPECT_EQ(c.calib.camera_id, "front");
  EXPECT_EQ(c.calib.lidar_model, "ot128");
  EXPECT_EQ(c.calib.camera_frame, "camera");
  EXPECT_EQ(c.calib.lidar_frame, "lidar");
  ASSERT_EQ(c.calib.boards.size(), 3u);
  EXPECT_EQ(c.BoardsPerFrame(), 7);
  // The figure the file's comment quotes: 200 x 7 x 4096 x 16 B = 92 MB.
  EXPECT_NEAR(c.SessionBufferBytes() / 1e6, 92.0, 0.5);
}

TEST(AgentConfigTest, SimulatorConfigIsAValidAgentConfigWithDefaults) {
  testing::TempDir dir;
  const std::string command = std::string(CALIBD_SIM_EXE) + " --frames 1 --out " +
                              dir.file("s.lcmlog") + " --config-out " + dir.file("calib.yaml") +
                              " > " + dir.file("sim.txt") + " 2>&1";
  ASSERT_EQ(std::system(command.c_str()), 0) << ReadText(dir.file("sim.txt"));
  CalibConfig calib;
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(LoadConfigFile(dir.file("calib.yaml"), &calib, &error)) << error;
  ASSERT_TRUE(LoadAgentConfig(dir.file("calib.yaml"), &c, &error)) << error;
  ExpectAgentAndEngineDefaults(c);
  EXPECT_EQ(c.calib.lidar_id, calib.lidar_id);
  EXPECT_EQ(c.calib.boards.size(), calib.boards.size());
  EXPECT_TRUE(c.calib.prior_T_camera_lidar.isApprox(calib.prior_T_camera_lidar, 1e-15));
}

TEST(AgentConfigTest, EmptySectionsKeepTheDefaults) {
  const std::string text = ReadText(kDefaultConfigPath);
  const std::string calib = text.substr(0, text.find("\nagent:\n") + 1);
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(ParseAgentConfigYaml(calib + "agent:\nengine:\n", &c, &error)) << error;
  ExpectAgentAndEngineDefaults(c);
}

TEST(AgentConfigTest, PartialSectionsKeepTheOtherDefaults) {
  const std::string text = ReadText(kDefaultConfigPath);
  const std::string calib = text.substr(0, text.find("\nagent:\n") + 1);
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(
      ParseAgentConfigYaml(calib + "agent:\n  max_frames: 300\n  store:\n    keep_previous: 9\n" +
                               "engine:\n  verdict:\n    min_boards: 40\n",
                           &c, &error))
      << error;
  EXPECT_EQ(c.max_frames, 300);
  EXPECT_EQ(c.store.keep_previous, 9);
  EXPECT_EQ(c.store.directory, "/var/lib/calibd");
  EXPECT_EQ(c.cache_dir, "");  // nothing kept unless the config says where
  EXPECT_EQ(c.engine.verdict.min_boards, 40);
  c.max_frames = 200;
  c.store.keep_previous = AgentConfig{}.store.keep_previous;
  c.engine.verdict.min_boards = VerdictConfig{}.min_boards;
  ExpectAgentAndEngineDefaults(c);
}

TEST(AgentConfigTest, EveryKeyReachesItsField) {
  const std::string text = ReadText(kDefaultConfigPath);
  const std::string calib = text.substr(0, text.find("\nagent:\n") + 1);
  const std::string yaml = calib + R"(
agent:
  lcm_url: memq://
  store: {directory: /tmp/calibd-store, keep_previous: 2}
  max_frames: 300
  max_boards_per_frame: 5
  max_points_per_board: 1024
  intake_queue_capacity: 8
  solve_heap_mb: 0
  max_duration_s: 45.5
  target_frames: 250
  min_frames: 40
  min_distance_bins: 2
  min_image_cells: 7
  stop_on_coverage: false
  pair_tolerance_ms: 12.5
  auto_commit: true
  status_rate_hz: 5
  health_rate_hz: 0.5
  software_version: calibd 0.1.0-fleet7
engine:
  method: indirect
  motion_compensation: false
  motion_window_s: 1.5
  board_pose_refinement: false
  solver_threads: 4
  stability_runs: 0
  grid: {range_deg: 12, step_deg: 2}
  verdict:
    verify_rotation_deg: 0.2
    verify_translation_m: 0.02
    max_rotation_deg: 5
    max_translation_m: 0.1
    min_frames: 15
    min_boards: 25
    max_rotation_sigma_deg: 0.06
    max_translation_sigma_m: 0.02
    min_plane_conditioning: 2e-5
    max_rotation_spread_deg: 0.3
    max_translation_spread_m: 0.04
    max_reprojection_mean_deg: 0.1
    max_residual_rms_m: 0.06
)";
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(ParseAgentConfigYaml(yaml, &c, &error)) << error;
  EXPECT_EQ(c.lcm_url, "memq://");
  EXPECT_EQ(c.store.directory, "/tmp/calibd-store");
  EXPECT_EQ(c.store.keep_previous, 2);
  EXPECT_EQ(c.max_frames, 300);
  EXPECT_EQ(c.max_boards_per_frame, 5);
  EXPECT_EQ(c.BoardsPerFrame(), 5);
  EXPECT_EQ(c.max_points_per_board, 1024);
  EXPECT_EQ(c.intake_queue_capacity, 8);
  EXPECT_EQ(c.solve_heap_mb, 0);
  EXPECT_EQ(c.max_duration_s, 45.5);
  EXPECT_EQ(c.target_frames, 250);
  EXPECT_EQ(c.min_frames, 40);
  EXPECT_EQ(c.min_distance_bins, 2);
  EXPECT_EQ(c.min_image_cells, 7);
  EXPECT_FALSE(c.stop_on_coverage);
  EXPECT_EQ(c.pair_tolerance_ms, 12.5);
  EXPECT_TRUE(c.auto_commit);
  EXPECT_EQ(c.status_rate_hz, 5.0);
  EXPECT_EQ(c.health_rate_hz, 0.5);
  EXPECT_EQ(c.software_version, "calibd 0.1.0-fleet7");
  EXPECT_EQ(c.SoftwareVersion(), "calibd 0.1.0-fleet7");
  const EngineConfig& e = c.engine;
  EXPECT_EQ(e.method, EngineConfig::Method::kIndirect);
  EXPECT_FALSE(e.motion.enabled);
  EXPECT_DOUBLE_EQ(e.motion.window_s, 1.5);
  EXPECT_FALSE(e.direct.refine_board_poses);
  EXPECT_EQ(e.direct.threads, 4);
  EXPECT_EQ(e.stability_runs, 0);
  EXPECT_EQ(e.grid.range_deg, 12.0);
  EXPECT_EQ(e.grid.step_deg, 2.0);
  EXPECT_EQ(e.verdict.verify_rotation_deg, 0.2);
  EXPECT_EQ(e.verdict.verify_translation_m, 0.02);
  EXPECT_EQ(e.verdict.max_rotation_deg, 5.0);
  EXPECT_EQ(e.verdict.max_translation_m, 0.1);
  EXPECT_EQ(e.verdict.min_frames, 15);
  EXPECT_EQ(e.verdict.min_boards, 25);
  EXPECT_EQ(e.verdict.max_rotation_sigma_deg, 0.06);
  EXPECT_EQ(e.verdict.max_translation_sigma_m, 0.02);
  EXPECT_EQ(e.verdict.min_plane_conditioning, 2e-5);
  EXPECT_EQ(e.verdict.max_rotation_spread_deg, 0.3);
  EXPECT_EQ(e.verdict.max_translation_spread_m, 0.04);
  EXPECT_EQ(e.verdict.max_reprojection_mean_deg, 0.1);
  EXPECT_EQ(e.verdict.max_residual_rms_m, 0.06);
}

TEST(AgentConfigTest, ErrorMessageNamesKeyRangeAndValue) {
  std::string yaml = ReadText(kDefaultConfigPath);
  const std::string line = "  max_frames: 200\n";
  ASSERT_NE(yaml.find(line), std::string::npos);
  yaml.replace(yaml.find(line), line.size(), "  max_frames: 3\n");
  AgentConfig c;
  c.max_frames = 77;
  std::string error;
  EXPECT_FALSE(ParseAgentConfigYaml(yaml, &c, &error));
  EXPECT_EQ(error, "agent.max_frames: must be in [10, 100000] (got 3)");
  EXPECT_EQ(c.max_frames, 77) << "a failed parse leaves the config untouched";
}

TEST(AgentConfigTest, FileErrorsStartWithThePath) {
  testing::TempDir dir;
  std::string yaml = ReadText(kDefaultConfigPath);
  const std::string line = "  target_frames: 200\n";
  yaml.replace(yaml.find(line), line.size(), "  target_frames: 0\n");
  WriteText(dir.file("calibd.yaml"), yaml);
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(LoadAgentConfig(dir.file("calibd.yaml"), &c, &error));
  EXPECT_EQ(error,
            dir.file("calibd.yaml") + ": agent.target_frames: must be in [1, 100000] (got 0)");
  EXPECT_FALSE(LoadAgentConfig(dir.file("missing.yaml"), &c, &error));
  EXPECT_NE(error.find(dir.file("missing.yaml")), std::string::npos) << error;
}

TEST(AgentConfigTest, MalformedFilesAreErrors) {
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(ParseAgentConfigYaml("", &c, &error));
  EXPECT_EQ(error, "<root>: must be a mapping");
  EXPECT_FALSE(ParseAgentConfigYaml("camera: [1, 2\n", &c, &error));
  EXPECT_EQ(error.rfind("YAML syntax", 0), 0u) << error;
  const std::string text = ReadText(kDefaultConfigPath);
  EXPECT_FALSE(
      ParseAgentConfigYaml(text.substr(0, text.find("\nagent:\n") + 1) + "agent: 5\n", &c, &error));
  EXPECT_EQ(error, "agent: must be a mapping");
}

TEST(AgentConfigTest, CodeBuiltConfigsAreValidatedToo) {
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(c.IsValid(&error)) << "no boards";
  EXPECT_EQ(error.rfind("boards", 0), 0u) << error;
  ASSERT_TRUE(LoadAgentConfig(kDefaultConfigPath, &c, &error)) << error;
  ASSERT_TRUE(c.IsValid(&error)) << error;

  AgentConfig big = c;
  big.max_frames = 100000;
  big.target_frames = 100000;
  big.max_points_per_board = 65536;
  EXPECT_FALSE(big.IsValid(&error));
  EXPECT_EQ(error.rfind("agent.max_points_per_board: the session buffer would take", 0), 0u)
      << error;

  AgentConfig longer = c;  // a session longer than the store is thinned, not refused
  longer.target_frames = 2000;
  EXPECT_TRUE(longer.IsValid(&error)) << error;
  AgentConfig small = c;  // but the store must hold what one drain brings, twice over
  small.max_frames = 10;
  small.intake_queue_capacity = 8;
  EXPECT_FALSE(small.IsValid(&error));
  EXPECT_EQ(
      error,
      "agent.max_frames: must be at least 2 x (agent.intake_queue_capacity + 1) = 18 (got 10)");

  AgentConfig grid = c;
  grid.engine.grid.refine_step_deg = 0.0;  // not in the file: the core's own check still runs
  EXPECT_FALSE(grid.IsValid(&error));
  EXPECT_EQ(error.rfind("engine: grid.refine_step_deg", 0), 0u) << error;

  AgentConfig version = c;
  version.software_version = "calibd\n1";
  EXPECT_FALSE(version.IsValid(&error));
  EXPECT_EQ(error.rfind("agent.software_version", 0), 0u) << error;
}

// The workshop diagnostics keys: off by default; when on, parsed (hex ids too) into the
// transport, UDS and GPIO configs, each error naming its key.
std::string DiagnosticsYaml() {
  std::string yaml = ReadText(kDefaultConfigPath);
  const std::string off = "  can:\n    enabled: false\n";
  const auto at = yaml.find(off);
  EXPECT_NE(at, std::string::npos);
  yaml.replace(at, off.size(), "  can:\n    enabled: true\n");
  return yaml;
}

TEST(AgentConfigTest, DiagnosticsKeysParse) {
  AgentConfig c;
  std::string error;
  ASSERT_TRUE(LoadAgentConfig(kDefaultConfigPath, &c, &error)) << error;
  EXPECT_FALSE(c.can_enabled);
  EXPECT_FALSE(c.gpio.interlock.enabled);

  std::string yaml = DiagnosticsYaml();
  for (const auto& [from, to] : std::vector<std::pair<std::string, std::string>>{
           {"physical_request_id: 0x7E0", "physical_request_id: 0x18DA10F1"},
           {"physical_response_id: 0x7E8", "physical_response_id: 0x18DAF110"},
           {"functional_request_id: 0x7DF", "functional_request_id: 0x18DB33F1"},
           {"extended_ids: false", "extended_ids: true"},
           {"st_min: 0 ", "st_min: 0xF5 "},
           {"lockout_delay_s: 10 ", "lockout_delay_s: 2.5 "},
           {"s3_ms: 5000 ", "s3_ms: 4000 "},
           {"    interlock:                  # input: calibration allowed only while asserted\n"
            "      enabled: false\n      chip: \"\"\n      line: \"\"",
            "    interlock:\n      enabled: true\n      chip: calibd-sim\n      line: "
            "interlock"}}) {
    const auto at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
  }
  ASSERT_TRUE(ParseAgentConfigYaml(yaml, &c, &error)) << error;
  EXPECT_TRUE(c.can_enabled);
  EXPECT_EQ(c.isotp.physical_request_id, 0x18DA10F1u);
  EXPECT_EQ(c.isotp.functional_request_id, 0x18DB33F1u);
  EXPECT_TRUE(c.isotp.extended_ids);
  EXPECT_EQ(c.isotp.st_min, 0xF5);
  EXPECT_EQ(c.isotp.pad_byte, 0xCC);
  EXPECT_EQ(c.status_frame_id, 0x3C0u);
  EXPECT_EQ(c.uds.lockout_delay_us, 2500000);
  EXPECT_EQ(c.uds.s3_us, 4000000);
  EXPECT_EQ(c.uds.secret_file, "/etc/calibd/uds_secret");
  EXPECT_TRUE(c.gpio.interlock.enabled);
  EXPECT_EQ(c.gpio.interlock.chip, "calibd-sim");
  EXPECT_EQ(c.gpio.start_button_debounce_ms, 30);
}

TEST(AgentConfigTest, DiagnosticsErrorsNameTheKey) {
  const std::string base = DiagnosticsYaml();
  for (const auto& [from, to, key] : std::vector<std::array<std::string, 3>>{
           {"interface: can0", "interface: a-name-longer-than-ifnamsiz", "agent.can.interface"},
           {"physical_request_id: 0x7E0", "physical_request_id: 0x800",
            "agent.can.physical_request_id"},
           {"status_frame_id: 0x3C0", "status_frame_id: 0x7E8", "agent.can.status_frame_id"},
           {"status_frame_id: 0x3C0", "status_frame_id: 0x1000", "agent.can.status_frame_id"},
           {"pad_byte: 0xCC", "pad_byte: lots", "agent.can.pad_byte"},
           {"can_fd: false", "can_fd: false\n    bitrate: 500000", "agent.can.bitrate"},
           {"max_key_attempts: 3 ", "max_key_attempts: 0 ", "agent.uds.max_key_attempts"},
           {"lockout_delay_s: 10 ", "lockout_delay_s: -1 ", "agent.uds.lockout_delay_s"},
           {"s3_ms: 5000 ", "s3_ms: 10 ", "agent.uds.s3_ms"},
           {"p2_star_ms: 5000 ", "p2_star_ms: 5005 ", "agent.uds.p2_star_ms"},
           {"ecu_serial: \"\" ", "ecu_serial: ECU-SERIAL-TOO-LONG-X ", "agent.uds.ecu_serial"},
           {"start_button_debounce_ms: 30", "start_button_debounce_ms: 5000",
            "agent.gpio.start_button_debounce_ms"},
           {"    status_lamp:                # output: idle off, running 1 Hz, success on, "
            "failure 4 Hz\n      enabled: false",
            "    status_lamp:\n      enabled: true", "agent.gpio.status_lamp.chip"},
       }) {
    std::string yaml = base;
    const auto at = yaml.find(from);
    ASSERT_NE(at, std::string::npos) << from;
    yaml.replace(at, from.size(), to);
    AgentConfig c;
    std::string error;
    EXPECT_FALSE(ParseAgentConfigYaml(yaml, &c, &error)) << to;
    EXPECT_EQ(error.rfind(key + ": ", 0), 0u) << to << " -> " << error;
  }
}

struct BadCase {
  std::string find, replace, expected_key;
};

class AgentConfigBadKeyTest : public ::testing::TestWithParam<BadCase> {};

TEST_P(AgentConfigBadKeyTest, ErrorNamesTheKey) {
  std::string yaml = ReadText(kDefaultConfigPath);
  const auto& p = GetParam();
  const auto pos = yaml.find(p.find);
  ASSERT_NE(pos, std::string::npos) << p.find;
  ASSERT_EQ(yaml.find(p.find, pos + 1), std::string::npos) << "ambiguous: " << p.find;
  yaml.replace(pos, p.find.size(), p.replace);
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(ParseAgentConfigYaml(yaml, &c, &error));
  EXPECT_EQ(error.rfind(p.expected_key + ": ", 0), 0u) << "error was: " << error;
}

INSTANTIATE_TEST_SUITE_P(
    Values, AgentConfigBadKeyTest,
    ::testing::Values(
        BadCase{"  lcm_url: \"\"\n", "  lcm_url: localhost\n", "agent.lcm_url"},
        BadCase{"directory: /var/lib/calibd\n", "directory: var/calibd\n", "agent.store.directory"},
        BadCase{"keep_previous: 5\n", "keep_previous: -1\n", "agent.store.keep_previous"},
        BadCase{"cache_dir: /var/cache/calibd\n", "cache_dir: cache\n", "agent.cache_dir"},
        BadCase{"max_boards_per_frame: 0\n", "max_boards_per_frame: 2\n",
                "agent.max_boards_per_frame"},
        BadCase{"max_points_per_board: 4096\n", "max_points_per_board: lots\n",
                "agent.max_points_per_board"},
        BadCase{"max_points_per_sweep: 400000\n", "max_points_per_sweep: 500\n",
                "agent.max_points_per_sweep"},
        BadCase{"intake_queue_capacity: 4\n", "intake_queue_capacity: 0\n",
                "agent.intake_queue_capacity"},
        BadCase{"solve_heap_mb: 32\n", "solve_heap_mb: 4096\n", "agent.solve_heap_mb"},
        BadCase{"max_duration_s: 120\n", "max_duration_s: 0\n", "agent.max_duration_s"},
        BadCase{"  min_frames: 50\n", "  min_frames: 0\n", "agent.min_frames"},
        BadCase{"min_distance_bins: 3\n", "min_distance_bins: 5\n", "agent.min_distance_bins"},
        BadCase{"min_image_cells: 4\n", "min_image_cells: 17\n", "agent.min_image_cells"},
        BadCase{"stop_on_coverage: true\n", "stop_on_coverage: sometimes\n",
                "agent.stop_on_coverage"},
        BadCase{"pair_tolerance_ms: 20\n", "pair_tolerance_ms: -1\n", "agent.pair_tolerance_ms"},
        BadCase{"auto_commit: false\n", "auto_commit: [false]\n", "agent.auto_commit"},
        BadCase{"status_rate_hz: 2\n", "status_rate_hz: 0\n", "agent.status_rate_hz"},
        BadCase{"health_rate_hz: 1\n", "health_rate_hz: .nan\n", "agent.health_rate_hz"},
        BadCase{"  method: direct\n", "  method: newton\n", "engine.method"},
        BadCase{"solver_threads: 2\n", "solver_threads: 0\n", "engine.solver_threads"},
        BadCase{"stability_runs: 4\n", "stability_runs: -4\n", "engine.stability_runs"},
        BadCase{"max_solve_frames: 200\n", "max_solve_frames: -1\n", "engine.max_solve_frames"},
        BadCase{"motion_compensation: true\n", "motion_compensation: 1\n",
                "engine.motion_compensation"},
        BadCase{"motion_window_s: 0.25\n", "motion_window_s: 3\n", "engine.motion_window_s"},
        BadCase{"max_time_offset_s: 0.1\n", "max_time_offset_s: .inf\n",
                "engine.verdict.max_time_offset_s"},
        BadCase{"range_deg: 9\n", "range_deg: 45\n", "engine.grid.range_deg"},
        BadCase{"step_deg: 1.5\n", "step_deg: 0.1\n", "engine.grid.step_deg"},
        BadCase{"verify_rotation_deg: 0.15", "verify_rotation_deg: 20",
                "engine.verdict.verify_rotation_deg"},
        BadCase{"    min_frames: 1 ", "    min_frames: 0 ", "engine.verdict.min_frames"},
        BadCase{"min_plane_conditioning: 1e-5\n", "min_plane_conditioning: 2\n",
                "engine.verdict.min_plane_conditioning"},
        BadCase{"max_residual_rms_m: 0.05\n", "max_residual_rms_m: .nan\n",
                "engine.verdict.max_residual_rms_m"},
        BadCase{"  fx: 3325", "  fx: -3325", "camera.intrinsics"},
        BadCase{"  model: ot128", "  model: hdl64", "lidar.model"}));

INSTANTIATE_TEST_SUITE_P(
    UnknownKeys, AgentConfigBadKeyTest,
    ::testing::Values(
        BadCase{"  max_frames: 200\n", "  max_frame: 200\n", "agent.max_frame"},
        BadCase{"keep_previous: 5\n", "keep_previous: 5\n    path: /x\n", "agent.store.path"},
        BadCase{"  method: direct\n", "  method: direct\n  colour: red\n", "engine.colour"},
        BadCase{"    max_residual_rms_m: 0.05\n",
                "    max_residual_rms_m: 0.05\n    max_rotaton_deg: 5\n",
                "engine.verdict.max_rotaton_deg"},
        BadCase{"    step_deg: 1.5\n", "    step_deg: 1.5\n    refine: false\n",
                "engine.grid.refine"},
        BadCase{"\nagent:\n", "\nagnet:\n", "agnet"}));

TEST(AgentConfigTest, UnknownKeySuggestsTheNearestKnownOne) {
  std::string yaml = ReadText(kDefaultConfigPath);
  const std::string line = "  max_frames: 200\n";
  yaml.replace(yaml.find(line), line.size(), "  max_frame: 200\n");
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(ParseAgentConfigYaml(yaml, &c, &error));
  EXPECT_EQ(error, "agent.max_frame: unknown key (did you mean max_frames?)");
}

// A key an older version read, whose meaning changed: refused with what replaced it, not taken
// silently nor called unknown.
TEST(AgentConfigTest, AReplacedKeyNamesItsReplacement) {
  std::string yaml = ReadText(kDefaultConfigPath);
  const std::string line = "    max_reprojection_mean_deg: 0.14\n";
  ASSERT_NE(yaml.find(line), std::string::npos);
  yaml.replace(yaml.find(line), line.size(), "    max_reprojection_mean_px: 8\n");
  AgentConfig c;
  std::string error;
  EXPECT_FALSE(ParseAgentConfigYaml(yaml, &c, &error));
  EXPECT_EQ(error.rfind("engine.verdict.max_reprojection_mean_px: no longer read", 0), 0u) << error;
  EXPECT_NE(error.find("max_reprojection_mean_deg"), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
