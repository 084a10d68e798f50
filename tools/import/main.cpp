// calibd-import: converts a folder of recorded frames (PCD point clouds and PNG/JPEG images) into
// an LCM log of calibd's camera and LiDAR channels, for calibd-agent and calibd-calibrate --log.
// See --help.

#include <cmath>
#include <cstdlib>
#include <iostream>
#include <string>

#include "calibd/camera_frame_t.hpp"
#include "calibd/channels.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/drivers/lcm_log.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "calibd/lidar_frame_t.hpp"
#include "command_line.hpp"
#include "tool_config.hpp"

namespace {

using namespace calibd;

constexpr const char* kHelp =
    R"(calibd-import: converts a folder of recorded frames into an LCM log of calibd's channels.

Usage: calibd-import --folder DIR --config calib.yaml [--intrinsics FILE] --out session.lcmlog
                     [--config-out FILE] [--quiet]

Writes every point cloud as a lidar_frame_t on CALIBD_LIDAR and every image as a camera_frame_t on
CALIBD_CAMERA, with the config's lidar.id and camera.id, in the order they would have arrived live
(an image at its capture time, a sweep when it completes: its start time plus one sweep of the
config's LiDAR model). calibd-agent replays the log (--lcm-url 'file://session.lcmlog?speed=0')
and calibd-calibrate --log reads it, with the same config.

Options:
  --folder DIR         point clouds (*.pcd: ascii, binary or binary_compressed; fields x y z,
                       optional intensity, ring, and a point time `time`/`t`/`timestamp`: float
                       seconds or integer nanoseconds after the sweep start) and images (*.png,
                       *.jpg, *.jpeg). With DIR/frames.csv the frames carry its times (below);
                       without it a cloud and an image pair by name stem (000123.pcd +
                       000123.png), stamped 1 s apart in stem order, camera and LiDAR at the same
                       instant (the files carry no times: keep engine.motion_window_s under 1 s
                       when the log is calibrated). Points with a NaN coordinate
                       (organized clouds) are dropped and counted
  --config FILE        calibration config: the camera and LiDAR ids, the LiDAR model (its sweep
                       time) and the camera's image size (required)
  --intrinsics FILE    camera intrinsics replacing the config's, whose camera section may then be
                       left out or hold only id and frame_id (OpenCV FileStorage YAML, ROS
                       camera_info YAML or JSON with K and D; see calibd-calibrate --help)
  --out FILE           the LCM log to write (required; overwritten)
  --config-out FILE    also write the config with the --intrinsics in it, for the agent and
                       calibd-calibrate --log
  --quiet              no progress or summary

Images are stored as they come when JPEG (ENCODING_JPEG), PNG converted to grey (ENCODING_MONO8);
every image must have the intrinsics' width and height. Any file that cannot be read or is
malformed stops the import with an error naming it (a log with silent gaps would calibrate on
less than the folder holds).

%CSV%

Exit codes: 0 written, 1 a file could not be read or written (the error names it), 2 bad option,
config or intrinsics.
)";

int Fail(int code, const std::string& message) {
  std::cerr << "calibd-import: " << message << "\n";
  return code;
}

}  // namespace

int main(int argc, char** argv) {
  std::string folder_path, config_path, intrinsics_path, out_path, config_out_path;
  bool quiet = false;
  tools::CommandLine line("calibd-import", argc, argv);
  while (line.Next()) {
    if (line.Is("--help") || line.Is("-h")) {
      std::cout << tools::HelpWithFramesCsv(kHelp);
      return 0;
    } else if (line.Is("--quiet")) {
      quiet = true;
    } else if (line.Is("--folder")) {
      line.Value(&folder_path);
    } else if (line.Is("--config")) {
      line.Value(&config_path);
    } else if (line.Is("--intrinsics")) {
      line.Value(&intrinsics_path);
    } else if (line.Is("--out")) {
      line.Value(&out_path);
    } else if (line.Is("--config-out")) {
      line.Value(&config_out_path);
    } else {
      line.Unknown();
    }
  }
  if (!line.failed() && (folder_path.empty() || config_path.empty() || out_path.empty()))
    line.Error("--folder, --config and --out are required (see --help)");
  if (line.failed()) return line.Fail(std::cerr);

  // As calibd-calibrate reads it: --intrinsics replace the config's camera section, and the
  // agent's sections are allowed (the same file serves all three).
  std::string error, config_text;
  CalibConfig config;
  if (!tools::LoadToolConfig(config_path, intrinsics_path, {"engine", "agent"}, &config,
                             &config_text, &error))
    return Fail(tools::kExitBadOption, error);
  LidarKind kind;
  if (!LidarKindFromName(config.lidar_model, &kind, &error))
    return Fail(tools::kExitBadOption, error);
  RecordedFolderOptions folder_options;
  folder_options.sweep_us =
      static_cast<int64_t>(std::llround(1e6 / MakeLidarModel(kind).frame_rate_hz));

  RecordedFolder folder;
  if (!ScanRecordedFolder(folder_path, folder_options, &folder, &error)) return Fail(1, error);
  if (!quiet)
    std::cerr << "calibd-import: " << folder.entries.size() << " files to convert, "
              << (folder.timed ? "times from frames.csv" : "paired by name stem") << "\n";
  LcmLogWriter log;
  if (!log.Open(out_path, &error)) return Fail(1, error);

  const std::string cam_channel(channels::kCamera.name), lidar_channel(channels::kLidar.name);
  camera_frame_t camera_msg;
  lidar_frame_t lidar_msg;
  PcdInfo info;
  int cameras = 0, lidars = 0;
  int64_t nan_dropped = 0, points = 0;
  for (size_t k = 0; k < folder.entries.size(); ++k) {
    const RecordedEntry& entry = folder.entries[k];
    if (entry.sensor == RecordedEntry::Sensor::kCamera) {
      if (!LoadRecordedImage(entry, config.camera_id, true, &camera_msg, &error))
        return Fail(1, error);
      if (camera_msg.width != config.camera.width || camera_msg.height != config.camera.height)
        return Fail(1, entry.path + ": image is " + std::to_string(camera_msg.width) + "x" +
                           std::to_string(camera_msg.height) + ", the intrinsics are for " +
                           std::to_string(config.camera.width) + "x" +
                           std::to_string(config.camera.height));
      if (!log.WriteMessage(cam_channel, entry.utime, camera_msg, &error)) return Fail(1, error);
      ++cameras;
    } else {
      if (!LoadRecordedCloud(entry, config.lidar_id, &lidar_msg, &info, &error))
        return Fail(1, error);
      // A sweep is published when it completes.
      if (!log.WriteMessage(lidar_channel, entry.utime + folder_options.sweep_us, lidar_msg,
                            &error))
        return Fail(1, error);
      ++lidars;
      nan_dropped += info.nan_dropped;
      points += lidar_msg.num_points;
    }
    if (!quiet && (k + 1) % 20 == 0)
      std::cerr << "calibd-import: " << (k + 1) << "/" << folder.entries.size() << " files\n";
  }
  if (!log.Close(&error)) return Fail(1, error);
  if (!config_out_path.empty() && !SaveConfigFile(config_out_path, config, &error))
    return Fail(1, error);
  if (!quiet) {
    std::cerr << "calibd-import: wrote " << cameras << " camera and " << lidars << " LiDAR frames ("
              << points << " points, " << nan_dropped << " NaN points dropped) to " << out_path
              << "\n";
    if (folder.unmatched_clouds + folder.unmatched_images > 0)
      std::cerr << "calibd-import: skipped " << folder.unmatched_clouds << " clouds and "
                << folder.unmatched_images << " images without a partner of the same stem\n";
  }
  return 0;
}
