#include "inspect.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <ostream>
#include <set>
#include <sstream>

#include "calibd/camera_frame_t.hpp"
#include "calibd/core/camera/target_survey.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/lidar_resolution.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/drivers/intrinsics_file.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd::tools {

namespace {

// A named mounting: the rotation of T_camera_lidar (camera x right, y down, z forward; LiDAR x
// forward, y left, z up, as calibd's conventions say).
struct Mounting {
  const char* name;
  const char* what;
  double R[3][3];
};
constexpr Mounting kMountings[] = {
    {"forward", "camera looking forward, LiDAR x forward", {{0, -1, 0}, {0, 0, -1}, {1, 0, 0}}},
    {"backward", "camera looking backward, LiDAR x forward", {{0, 1, 0}, {0, 0, -1}, {-1, 0, 0}}},
    {"left", "camera looking left, LiDAR x forward", {{1, 0, 0}, {0, 0, -1}, {0, 1, 0}}},
    {"right", "camera looking right, LiDAR x forward", {{-1, 0, 0}, {0, 0, -1}, {0, -1, 0}}},
};

// What one LiDAR frame says about its sensor.
struct CloudSurvey {
  int points = 0;
  int rings = 0;  // distinct ring values >= 0
  double elevation_min_deg = 0.0, elevation_max_deg = 0.0;
  std::string model;  // a named model that fits, or "generic"
};

CloudSurvey SurveyCloud(const lidar_frame_t& m) {
  CloudSurvey s;
  std::map<int, std::vector<double>> elevations;  // per ring
  double lo = 1e9, hi = -1e9;
  for (int i = 0; i < m.num_points; ++i) {
    const double x = m.x[i], y = m.y[i], z = m.z[i];
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) continue;
    const double r = std::sqrt(x * x + y * y);
    if (r + std::abs(z) < 0.1) continue;
    ++s.points;
    const double el = std::atan2(z, r) * kRad2Deg;
    lo = std::min(lo, el);
    hi = std::max(hi, el);
    if (!m.ring.empty() && m.ring[i] >= 0) elevations[m.ring[i]].push_back(el);
  }
  s.rings = static_cast<int>(elevations.size());
  s.elevation_min_deg = s.points > 0 ? lo : 0.0;
  s.elevation_max_deg = s.points > 0 ? hi : 0.0;
  s.model = "generic";
  if (s.rings < 2) return s;
  // Each seen ring's median elevation against the named models' ring tables (rings that saw
  // nothing, e.g. the sky indoors, are simply absent): a model fits when every seen ring index
  // exists in it and its elevations match to within 0.5 deg after a common offset (a sensor
  // mounted tilted shifts them all).
  std::vector<std::pair<int, double>> medians;  // ring, median elevation
  for (auto& [ring, e] : elevations) {
    std::nth_element(e.begin(), e.begin() + static_cast<long>(e.size() / 2), e.end());
    medians.emplace_back(ring, e[e.size() / 2]);
  }
  for (LidarKind kind : SimulatedLidarKinds()) {
    const LidarModel model = MakeLidarModel(kind);
    const auto rings = static_cast<int>(model.ring_elevation_deg.size());
    if (!model.has_rings || medians.back().first >= rings) continue;
    std::vector<double> offsets;
    for (const auto& [ring, el] : medians) offsets.push_back(el - model.ring_elevation_deg[ring]);
    std::nth_element(offsets.begin(), offsets.begin() + static_cast<long>(offsets.size() / 2),
                     offsets.end());
    const double offset = offsets[offsets.size() / 2];
    const bool fits = std::all_of(medians.begin(), medians.end(), [&](const auto& seen) {
      return std::abs(seen.second - offset - model.ring_elevation_deg[seen.first]) < 0.5;
    });
    if (fits) {
      s.model = model.name;
      break;
    }
  }
  return s;
}

}  // namespace

const char* InspectMountings() { return "forward, backward, left, right"; }

int RunInspect(const InspectOptions& options, std::ostream& out, std::ostream& err) {
  const Mounting* mounting = nullptr;
  for (const Mounting& m : kMountings)
    if (options.mounting == m.name) mounting = &m;
  if (!mounting) {
    err << "calibd-calibrate: --mounting must be one of " << InspectMountings() << " (got '"
        << options.mounting << "')\n";
    return 2;
  }
  std::string error;
  CameraIntrinsics intrinsics;
  const bool have_intrinsics = !options.intrinsics_path.empty();
  if (have_intrinsics && !LoadIntrinsicsFile(options.intrinsics_path, &intrinsics, &error)) {
    err << "calibd-calibrate: --intrinsics: " << error << "\n";
    return 2;
  }
  RecordedFolder folder;
  if (!ScanRecordedFolder(options.folder, RecordedFolderOptions{}, &folder, &error)) {
    err << "calibd-calibrate: " << error << "\n";
    return 2;
  }
  TargetSurvey survey;
  if (!survey.ok()) {
    err << "calibd-calibrate: " << survey.error() << "\n";
    return 2;
  }

  // Per image: tags, or else a checkerboard. Per cloud: points, rings, model.
  std::map<std::pair<std::string, int>, std::pair<int, double>> tags;  // seen in, largest px
  std::map<std::pair<int, int>, std::pair<int, double>> checkers;      // seen in, largest px
  std::map<std::string, int> models;
  int width = 0, height = 0, images = 0, clouds = 0, unreadable = 0;
  out << "file | what it shows\n";
  for (const RecordedEntry& entry : folder.entries) {
    const std::string name = entry.path.substr(entry.path.find_last_of('/') + 1);
    if (entry.sensor == RecordedEntry::Sensor::kCamera) {
      camera_frame_t msg;
      if (!LoadRecordedImage(entry, "camera", false, &msg, &error)) {
        err << "calibd-calibrate: skipped: " << error << "\n";
        ++unreadable;
        continue;
      }
      ++images;
      width = msg.width;
      height = msg.height;
      const ImageView view{msg.data.data(), msg.width, msg.height, msg.width};
      const std::vector<TagSighting> seen = survey.Tags(view);
      out << name << " | " << msg.width << " x " << msg.height << " px;";
      for (const TagSighting& t : seen) {
        out << " tag " << t.family << " id " << t.id << " (" << FixedDecimal(t.side_px, 0)
            << " px)";
        auto& [count, px] = tags[{t.family, t.id}];
        ++count;
        px = std::max(px, t.side_px);
      }
      CheckerSighting c;
      if (seen.empty() && survey.Checkerboard(view, &c)) {
        out << " checkerboard " << c.inner_cols << " x " << c.inner_rows << " inner corners ("
            << FixedDecimal(c.square_px, 0) << " px squares)";
        auto& [count, px] = checkers[{c.inner_cols, c.inner_rows}];
        ++count;
        px = std::max(px, c.square_px);
      } else if (seen.empty()) {
        out << " no tag or checkerboard";
      }
      out << "\n";
    } else {
      lidar_frame_t msg;
      PcdInfo info;
      if (!LoadRecordedCloud(entry, "lidar", &msg, &info, &error)) {
        err << "calibd-calibrate: skipped: " << error << "\n";
        ++unreadable;
        continue;
      }
      ++clouds;
      const CloudSurvey s = SurveyCloud(msg);
      ++models[s.model];
      out << name << " | " << s.points << " points, ";
      if (s.rings > 0)
        out << s.rings << " rings, ";
      else
        out << "no ring field, ";
      out << "elevation " << FixedDecimal(s.elevation_min_deg, 1) << " .. "
          << FixedDecimal(s.elevation_max_deg, 1) << " deg; model " << s.model << "\n";
    }
  }
  out << "\n" << images << " images, " << clouds << " point clouds";
  if (unreadable > 0) out << ", " << unreadable << " unreadable (named above)";
  out << "\n";

  // The model most clouds fit.
  std::string model = "generic";
  int best = 0;
  for (const auto& [name, count] : models)
    if (count > best) {
      best = count;
      model = name;
    }

  std::ostringstream yaml;
  yaml << "# Starter config written by calibd-calibrate --inspect from " << options.folder
       << ".\n# Replace every TODO before calibrating: calibd-calibrate refuses a config that "
          "still holds one.\n";
  yaml << "camera:\n  id: camera\n"
          "  # principal_point_sigma_px: 1.0  # the sigma of cx, cy (px) your intrinsic "
          "calibration\n"
          "  #   states: uncomment and set it. Left out, only the tags measure the principal "
          "point,\n"
          "  #   and a result is accepted only from boards close and slanted enough to.\n";
  if (!have_intrinsics) {
    yaml << "  width: " << width << "\n  height: " << height
         << "\n  fx: TODO  # focal lengths and principal point, px (or give --intrinsics FILE)\n"
            "  fy: TODO\n  cx: TODO\n  cy: TODO\n  model: radtan  # or kannala_brandt (fisheye)\n"
            "  distortion: [0, 0, 0, 0, 0]  # TODO: k1, k2, p1, p2, k3\n";
  }
  yaml << "lidar:\n  id: lidar\n  model: " << model << "  # from " << best << " of " << clouds
       << " clouds (" << LidarModelNames() << ")\n";
  yaml << "boards:\n";
  int id = 0;
  for (const auto& [key, seen] : tags) {
    yaml << "  - id: " << id++ << "  # seen in " << seen.first << " images, up to "
         << FixedDecimal(seen.second, 0) << " px\n"
         << "    width_m: TODO   # board edge, m: measure it\n    height_m: TODO\n"
         << "    pattern: apriltag\n    tag_family: " << key.first << "\n    tag_id: " << key.second
         << "\n    tag_size_m: TODO  # the tag's black square, m\n"
         << "    tag_offset_m: [0, 0]  # TODO if the tag is not centred on the board\n";
  }
  for (const auto& [key, seen] : checkers) {
    yaml << "  - id: " << id++ << "  # seen in " << seen.first << " images, squares up to "
         << FixedDecimal(seen.second, 0) << " px\n"
         << "    width_m: TODO\n    height_m: TODO\n    pattern: checkerboard\n"
         << "    checker_inner_cols: " << key.first << "\n    checker_inner_rows: " << key.second
         << "\n    checker_square_size_m: TODO  # side of one square, m\n"
         << "    tag_offset_m: [0, 0]  # TODO if the pattern is not centred on the board\n";
  }
  if (id == 0) yaml << "  []  # TODO: no tag or checkerboard was found in any image\n";
  yaml << "prior:\n  # " << mounting->what
       << ". TODO: the translation, LiDAR origin in the camera frame, m (tape measure).\n"
       << "  T_camera_lidar:\n";
  for (int r = 0; r < 3; ++r)
    yaml << "    - [" << mounting->R[r][0] << ", " << mounting->R[r][1] << ", " << mounting->R[r][2]
         << ", 0]\n";
  yaml << "    - [0, 0, 0, 1]\n";

  if (options.config_out.empty()) {
    out << "\n" << yaml.str();
  } else {
    if (!WriteFileAtomic(options.config_out, yaml.str(), &error)) {
      err << "calibd-calibrate: " << error << "\n";
      return 2;
    }
    out << "starter config written to " << options.config_out << "\n";
  }
  return 0;
}

}  // namespace calibd::tools
