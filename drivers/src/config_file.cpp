#include "calibd/drivers/config_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <iomanip>
#include <sstream>
#include <utility>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd {

namespace {

// lidar.generic.pattern's names, for reading and writing.
constexpr std::pair<GenericLidarConfig::Pattern, const char*> kGenericPatterns[] = {
    {GenericLidarConfig::Pattern::kAuto, "auto"},
    {GenericLidarConfig::Pattern::kLines, "lines"},
    {GenericLidarConfig::Pattern::kIrregular, "irregular"},
};

// Thrown only inside this file, to carry the failing key up to the parse entry point.
struct KeyError {
  std::string key, what;
};

YAML::Node Child(const YAML::Node& parent, const std::string& name, const std::string& key) {
  const YAML::Node n = parent[name];
  if (!n) throw KeyError{key, "missing"};
  return n;
}

template <typename T>
T Get(const YAML::Node& parent, const std::string& name, const std::string& key) {
  const YAML::Node n = Child(parent, name, key);
  try {
    return n.as<T>();
  } catch (const YAML::Exception&) {
    throw KeyError{key, "has the wrong type"};
  }
}

template <typename T>
T GetOr(const YAML::Node& parent, const std::string& name, const std::string& key, T fallback) {
  if (!parent[name]) return fallback;
  return Get<T>(parent, name, key);
}

void CheckKnown(const YAML::Node& map, std::initializer_list<const char*> known,
                const std::string& prefix, const std::vector<std::string>& also_known = {}) {
  if (!map.IsMap()) throw KeyError{prefix.empty() ? "<root>" : prefix, "must be a mapping"};
  for (const auto& kv : map) {
    const std::string k = kv.first.as<std::string>();
    bool ok = false;
    for (const char* n : known) ok = ok || k == n;
    for (const std::string& n : also_known) ok = ok || k == n;
    if (!ok) throw KeyError{prefix.empty() ? k : prefix + "." + k, "unknown key"};
  }
}

// Sensor ids match the LCM messages' camera_id/lidar_id, and frame ids go into the exported
// files (ROS, URDF, JSON): 1-64 printable characters without spaces. (fuzz_calib_config found
// an id ending in a control character that ConfigToYaml could not write back as it was read.)
std::string Name(const std::string& value, const std::string& key) {
  bool ok = !value.empty() && value.size() <= 64;
  for (const char ch : value) ok = ok && ch > ' ' && ch < 0x7F;
  if (!ok) throw KeyError{key, "must be 1-64 printable characters without spaces"};
  return value;
}

// camera.principal_point_sigma_px, with the intrinsics or beside intrinsics given elsewhere.
void ParsePrincipalPointSigma(const YAML::Node& cam, CalibConfig* c) {
  c->principal_point_sigma_px =
      GetOr<double>(cam, "principal_point_sigma_px", "camera.principal_point_sigma_px", 0.0);
}

// The `camera:` section: its ids, and its intrinsics unless given elsewhere.
void ParseCamera(const YAML::Node& root, const CameraIntrinsics* intrinsics, CalibConfig* c) {
  const YAML::Node cam = intrinsics ? root["camera"] : Child(root, "camera", "camera");
  if (intrinsics && (!cam || !cam.IsMap() || !cam["width"])) {
    // Intrinsics given elsewhere and none here: the section is optional, its ids are.
    c->camera = *intrinsics;
    if (!cam) return;
    CheckKnown(cam, {"id", "frame_id", "principal_point_sigma_px"}, "camera");
    ParsePrincipalPointSigma(cam, c);
    c->camera_id = Name(GetOr<std::string>(cam, "id", "camera.id", c->camera_id), "camera.id");
    c->camera_frame = Name(GetOr<std::string>(cam, "frame_id", "camera.frame_id", c->camera_frame),
                           "camera.frame_id");
    return;
  }
  CheckKnown(cam,
             {"id", "frame_id", "width", "height", "fx", "fy", "cx", "cy", "model", "distortion",
              "principal_point_sigma_px"},
             "camera");
  ParsePrincipalPointSigma(cam, c);
  c->camera_id = Name(Get<std::string>(cam, "id", "camera.id"), "camera.id");
  c->camera_frame = Name(GetOr<std::string>(cam, "frame_id", "camera.frame_id", c->camera_frame),
                         "camera.frame_id");
  c->camera.width = Get<int>(cam, "width", "camera.width");
  c->camera.height = Get<int>(cam, "height", "camera.height");
  c->camera.fx = Get<double>(cam, "fx", "camera.fx");
  c->camera.fy = Get<double>(cam, "fy", "camera.fy");
  c->camera.cx = Get<double>(cam, "cx", "camera.cx");
  c->camera.cy = Get<double>(cam, "cy", "camera.cy");
  const auto model = GetOr<std::string>(cam, "model", "camera.model", "radtan");
  const auto dist = Get<std::vector<double>>(cam, "distortion", "camera.distortion");
  c->camera.k1 = c->camera.k2 = c->camera.p1 = c->camera.p2 = c->camera.k3 = c->camera.k4 = 0.0;
  if (model == "radtan") {
    c->camera.model = DistortionModel::kRadTan;
    if (dist.size() != 5) throw KeyError{"camera.distortion", "radtan needs [k1, k2, p1, p2, k3]"};
    c->camera.k1 = dist[0];
    c->camera.k2 = dist[1];
    c->camera.p1 = dist[2];
    c->camera.p2 = dist[3];
    c->camera.k3 = dist[4];
  } else if (model == "kannala_brandt") {
    c->camera.model = DistortionModel::kKannalaBrandt;
    if (dist.size() != 4)
      throw KeyError{"camera.distortion", "kannala_brandt needs [k1, k2, k3, k4]"};
    c->camera.k1 = dist[0];
    c->camera.k2 = dist[1];
    c->camera.k3 = dist[2];
    c->camera.k4 = dist[3];
  } else {
    throw KeyError{"camera.model", "must be radtan or kannala_brandt (got '" + model + "')"};
  }
  if (intrinsics) c->camera = *intrinsics;  // a full section, replaced
}

void ParseOrThrow(const YAML::Node& root, const ConfigParseOptions& options, CalibConfig* c) {
  CheckKnown(root, {"camera", "lidar", "boards", "prior"}, "", options.other_sections);
  ParseCamera(root, options.intrinsics, c);

  const YAML::Node lidar = Child(root, "lidar", "lidar");
  CheckKnown(lidar, {"id", "frame_id", "model", "generic"}, "lidar");
  c->lidar_id = Name(Get<std::string>(lidar, "id", "lidar.id"), "lidar.id");
  c->lidar_frame = Name(GetOr<std::string>(lidar, "frame_id", "lidar.frame_id", c->lidar_frame),
                        "lidar.frame_id");
  c->lidar_model = Get<std::string>(lidar, "model", "lidar.model");
  if (const YAML::Node g = lidar["generic"]) {
    // lidar.model generic: every value optional, 0 (or absent) = estimated from the data.
    CheckKnown(g,
               {"azimuth_resolution_deg", "elevation_resolution_deg", "azimuth_min_deg",
                "azimuth_max_deg", "elevation_min_deg", "elevation_max_deg", "max_points",
                "frame_rate_hz", "estimation_frames", "pattern", "points_per_frame"},
               "lidar.generic");
    GenericLidarConfig& gc = c->lidar_generic;
    for (auto [name, field] :
         {std::pair<const char*, double*>{"azimuth_resolution_deg", &gc.azimuth_resolution_deg},
          {"elevation_resolution_deg", &gc.elevation_resolution_deg},
          {"azimuth_min_deg", &gc.azimuth_min_deg},
          {"azimuth_max_deg", &gc.azimuth_max_deg},
          {"elevation_min_deg", &gc.elevation_min_deg},
          {"elevation_max_deg", &gc.elevation_max_deg},
          {"frame_rate_hz", &gc.frame_rate_hz}})
      *field = GetOr<double>(g, name, std::string("lidar.generic.") + name, *field);
    gc.max_points = GetOr<int>(g, "max_points", "lidar.generic.max_points", gc.max_points);
    gc.estimation_frames =
        GetOr<int>(g, "estimation_frames", "lidar.generic.estimation_frames", gc.estimation_frames);
    const auto pattern = GetOr<std::string>(g, "pattern", "lidar.generic.pattern", "auto");
    const auto* named = std::find_if(std::begin(kGenericPatterns), std::end(kGenericPatterns),
                                     [&](const auto& p) { return pattern == p.second; });
    if (named == std::end(kGenericPatterns))
      throw KeyError{"lidar.generic.pattern",
                     "must be auto, lines or irregular (got '" + pattern + "')"};
    gc.pattern = named->first;
    gc.points_per_frame =
        GetOr<int>(g, "points_per_frame", "lidar.generic.points_per_frame", gc.points_per_frame);
  }

  const YAML::Node boards = Child(root, "boards", "boards");
  if (!boards.IsSequence()) throw KeyError{"boards", "must be a list"};
  c->boards.clear();
  for (size_t i = 0; i < boards.size(); ++i) {
    const std::string key = "boards[" + std::to_string(i) + "]";
    const YAML::Node b = boards[i];
    CheckKnown(
        b,
        {"id", "width_m", "height_m", "pattern", "tag_family", "tag_id", "tag_size_m",
         "tag_offset_m", "checker_inner_rows", "checker_inner_cols", "checker_square_size_m"},
        key);
    BoardGeometry g;
    g.board_id = Get<int>(b, "id", key + ".id");
    g.width_m = Get<double>(b, "width_m", key + ".width_m");
    g.height_m = GetOr<double>(b, "height_m", key + ".height_m", g.width_m);
    const auto pattern = GetOr<std::string>(b, "pattern", key + ".pattern", "apriltag");
    if (pattern == "apriltag") {
      g.pattern = BoardGeometry::PatternKind::kAprilTag;
      g.tag_family = GetOr<std::string>(b, "tag_family", key + ".tag_family", g.tag_family);
      g.tag_id = GetOr<int>(b, "tag_id", key + ".tag_id", g.board_id);
      g.tag_size_m = Get<double>(b, "tag_size_m", key + ".tag_size_m");
    } else if (pattern == "checkerboard") {
      g.pattern = BoardGeometry::PatternKind::kCheckerboard;
      g.checker_inner_rows = Get<int>(b, "checker_inner_rows", key + ".checker_inner_rows");
      g.checker_inner_cols = Get<int>(b, "checker_inner_cols", key + ".checker_inner_cols");
      g.checker_square_size_m =
          Get<double>(b, "checker_square_size_m", key + ".checker_square_size_m");
    } else {
      throw KeyError{key + ".pattern", "must be apriltag or checkerboard (got '" + pattern + "')"};
    }
    const auto off =
        GetOr<std::vector<double>>(b, "tag_offset_m", key + ".tag_offset_m", {0.0, 0.0});
    if (off.size() != 2) throw KeyError{key + ".tag_offset_m", "must be [x, y]"};
    g.tag_offset_m = Eigen::Vector2d(off[0], off[1]);
    c->boards.push_back(g);
  }

  const YAML::Node prior = Child(root, "prior", "prior");
  CheckKnown(prior, {"T_camera_lidar"}, "prior");
  const YAML::Node T = Child(prior, "T_camera_lidar", "prior.T_camera_lidar");
  if (!T.IsSequence() || T.size() != 4)
    throw KeyError{"prior.T_camera_lidar", "must be 4 rows of 4 numbers"};
  Pose pose = Pose::Identity();
  for (int r = 0; r < 4; ++r) {
    const std::string key = "prior.T_camera_lidar[" + std::to_string(r) + "]";
    std::vector<double> row;
    try {
      row = T[r].as<std::vector<double>>();
    } catch (const YAML::Exception&) {
      throw KeyError{key, "must be a row of 4 numbers"};
    }
    if (row.size() != 4) throw KeyError{key, "must be a row of 4 numbers"};
    for (int col = 0; col < 4; ++col) pose.matrix()(r, col) = row[col];
  }
  if (!pose.matrix().row(3).isApprox(Eigen::RowVector4d(0, 0, 0, 1)))
    throw KeyError{"prior.T_camera_lidar[3]", "must be [0, 0, 0, 1]"};
  c->prior_T_camera_lidar = pose;
}

}  // namespace

std::string ShortestDecimal(double v) {
  for (int digits = 6; digits <= 17; ++digits) {
    std::ostringstream o;
    o << std::setprecision(digits) << v;
    if (std::stod(o.str()) == v) return o.str();
  }
  return std::to_string(v);
}

bool ParseConfigYaml(const std::string& text, CalibConfig* config, std::string* error,
                     const ConfigParseOptions& options) {
  CalibConfig c;
  try {
    ParseOrThrow(YAML::Load(text), options, &c);
  } catch (const KeyError& e) {
    if (error) *error = e.key + ": " + e.what;
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = std::string("YAML syntax: ") + e.what();
    return false;
  }
  if (!c.IsValid(error)) return false;
  *config = c;
  return true;
}

bool LoadConfigFile(const std::string& path, CalibConfig* config, std::string* error) {
  const auto parse = [](const std::string& text, CalibConfig* c, std::string* e) {
    return ParseConfigYaml(text, c, e);
  };
  return LoadTextFile<CalibConfig>(path, parse, config, error);
}

std::string ConfigToYaml(const CalibConfig& c) {
  std::ostringstream o;
  const auto& k = c.camera;
  o << "# calibd calibration config: sensors, intrinsics, boards and the prior extrinsic.\n";
  o << "camera:\n  id: " << c.camera_id << "\n  frame_id: " << c.camera_frame
    << "\n  width: " << k.width << "\n  height: " << k.height << "\n  fx: " << ShortestDecimal(k.fx)
    << "\n  fy: " << ShortestDecimal(k.fy) << "\n  cx: " << ShortestDecimal(k.cx)
    << "\n  cy: " << ShortestDecimal(k.cy);
  if (c.principal_point_sigma_px > 0.0)
    o << "\n  principal_point_sigma_px: " << ShortestDecimal(c.principal_point_sigma_px)
      << "  # the intrinsic calibration's stated sigma of cx, cy";
  if (k.model == DistortionModel::kKannalaBrandt) {
    o << "\n  model: kannala_brandt\n  distortion: [" << ShortestDecimal(k.k1) << ", "
      << ShortestDecimal(k.k2) << ", " << ShortestDecimal(k.k3) << ", " << ShortestDecimal(k.k4)
      << "]  # k1, k2, k3, k4 (OpenCV fisheye)\n";
  } else {
    o << "\n  model: radtan\n  distortion: [" << ShortestDecimal(k.k1) << ", "
      << ShortestDecimal(k.k2) << ", " << ShortestDecimal(k.p1) << ", " << ShortestDecimal(k.p2)
      << ", " << ShortestDecimal(k.k3) << "]  # k1, k2, p1, p2, k3 (OpenCV radial-tangential)\n";
  }
  o << "lidar:\n  id: " << c.lidar_id << "\n  frame_id: " << c.lidar_frame
    << "\n  model: " << c.lidar_model << "\n";
  if (c.lidar_model == "generic") {
    const GenericLidarConfig& g = c.lidar_generic;
    o << "  generic:  # 0: estimated from the first frames\n    azimuth_resolution_deg: "
      << ShortestDecimal(g.azimuth_resolution_deg)
      << "\n    elevation_resolution_deg: " << ShortestDecimal(g.elevation_resolution_deg)
      << "\n    azimuth_min_deg: " << ShortestDecimal(g.azimuth_min_deg)
      << "\n    azimuth_max_deg: " << ShortestDecimal(g.azimuth_max_deg)
      << "\n    elevation_min_deg: " << ShortestDecimal(g.elevation_min_deg)
      << "\n    elevation_max_deg: " << ShortestDecimal(g.elevation_max_deg)
      << "\n    max_points: " << g.max_points
      << "\n    frame_rate_hz: " << ShortestDecimal(g.frame_rate_hz)
      << "\n    estimation_frames: " << g.estimation_frames << "\n    pattern: "
      << std::find_if(std::begin(kGenericPatterns), std::end(kGenericPatterns),
                      [&](const auto& p) { return g.pattern == p.first; })
             ->second
      << "\n    points_per_frame: " << g.points_per_frame << "\n";
  }
  o << "boards:\n";
  for (const auto& b : c.boards) {
    o << "  - id: " << b.board_id << "\n    width_m: " << ShortestDecimal(b.width_m)
      << "\n    height_m: " << ShortestDecimal(b.height_m);
    if (b.pattern == BoardGeometry::PatternKind::kCheckerboard) {
      o << "\n    pattern: checkerboard\n    checker_inner_rows: " << b.checker_inner_rows
        << "\n    checker_inner_cols: " << b.checker_inner_cols
        << "\n    checker_square_size_m: " << ShortestDecimal(b.checker_square_size_m);
    } else {
      o << "\n    pattern: apriltag\n    tag_family: " << b.tag_family
        << "\n    tag_id: " << b.tag_id << "\n    tag_size_m: " << ShortestDecimal(b.tag_size_m);
    }
    o << "\n    tag_offset_m: [" << ShortestDecimal(b.tag_offset_m.x()) << ", "
      << ShortestDecimal(b.tag_offset_m.y()) << "]  # pattern centre on the board\n";
  }
  o << "prior:\n  # maps LiDAR points into the camera frame (camera: x right, y down, z forward)\n";
  o << "  T_camera_lidar:\n";
  for (int r = 0; r < 4; ++r) {
    o << "    - [";
    for (int col = 0; col < 4; ++col)
      o << ShortestDecimal(c.prior_T_camera_lidar.matrix()(r, col)) << (col < 3 ? ", " : "]\n");
  }
  return o.str();
}

bool SaveConfigFile(const std::string& path, const CalibConfig& config, std::string* error) {
  return WriteFileAtomic(path, ConfigToYaml(config), error);
}

}  // namespace calibd
