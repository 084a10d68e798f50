#include "calibd/drivers/intrinsics_file.hpp"

#include <yaml-cpp/yaml.h>

#include <algorithm>
#include <cmath>
#include <nlohmann/json.hpp>
#include <optional>
#include <vector>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd {

namespace {

// What every format boils down to, before the checks common to all of them.
struct RawIntrinsics {
  std::optional<std::vector<double>> K, D;
  std::optional<double> width, height;
  std::string model;  ///< empty: by default radial-tangential
  std::string k_key = "camera_matrix", d_key = "distortion_coefficients";
  std::string width_key = "image_width", height_key = "image_height";
};

// Thrown only inside this file, to carry the failing key up to ParseIntrinsics.
struct KeyError {
  std::string key, what;
};

constexpr const char* kKKeys[] = {"camera_matrix", "K"};
constexpr const char* kDKeys[] = {"distortion_coefficients", "D", "dist_coeffs"};
constexpr const char* kWidthKeys[] = {"image_width", "width"};
constexpr const char* kHeightKeys[] = {"image_height", "height"};

// --- plain YAML (ROS camera_info) ---

void YamlNumbers(const YAML::Node& n, const std::string& key, std::vector<double>* out) {
  if (n.IsMap()) {
    // A ROS {rows, cols, data} map or an OpenCV !!opencv-matrix (rows, cols, dt, data).
    if (!n["data"]) throw KeyError{key, "a mapping without data"};
    const size_t first = out->size();
    YamlNumbers(n["data"], key + ".data", out);
    if (n["rows"] || n["cols"]) {
      int rows = -1, cols = -1;
      try {
        rows = n["rows"].as<int>();
        cols = n["cols"].as<int>();
      } catch (const YAML::Exception&) {
        throw KeyError{key, "a matrix needs rows and cols of 0-16"};
      }
      if (rows < 0 || cols < 0 || rows > 16 || cols > 16)
        throw KeyError{key, "a matrix needs rows and cols of 0-16"};
      if (out->size() - first != static_cast<size_t>(rows * cols))
        throw KeyError{key, "a " + std::to_string(rows) + "x" + std::to_string(cols) +
                                " matrix needs " + std::to_string(rows * cols) + " numbers, got " +
                                std::to_string(out->size() - first)};
    }
    return;
  }
  if (n.IsSequence()) {
    for (const auto& e : n) YamlNumbers(e, key, out);
    return;
  }
  try {
    out->push_back(n.as<double>());
  } catch (const YAML::Exception&) {
    throw KeyError{key, "must be numbers"};
  }
}

void ReadYaml(const std::string& text, RawIntrinsics* raw) {
  const YAML::Node root = YAML::Load(text);
  if (!root.IsMap()) throw KeyError{"<root>", "must be a mapping"};
  for (const char* k : kKKeys)
    if (!raw->K && root[k]) {
      raw->K.emplace();
      raw->k_key = k;
      YamlNumbers(root[k], k, &*raw->K);
    }
  for (const char* k : kDKeys)
    if (!raw->D && root[k]) {
      raw->D.emplace();
      raw->d_key = k;
      YamlNumbers(root[k], k, &*raw->D);
    }
  auto number = [&](const char* const* keys, size_t n, std::optional<double>* v,
                    std::string* used) {
    for (size_t i = 0; i < n && !*v; ++i) {
      if (!root[keys[i]]) continue;
      *used = keys[i];
      try {
        *v = root[keys[i]].as<double>();
      } catch (const YAML::Exception&) {
        throw KeyError{keys[i], "must be a number"};
      }
    }
  };
  number(kWidthKeys, 2, &raw->width, &raw->width_key);
  number(kHeightKeys, 2, &raw->height, &raw->height_key);
  if (root["distortion_model"]) {
    try {
      raw->model = root["distortion_model"].as<std::string>();
    } catch (const YAML::Exception&) {
      throw KeyError{"distortion_model", "must be a string"};
    }
  }
}

// --- JSON ---

void JsonNumbers(const nlohmann::json& n, const std::string& key, std::vector<double>* out) {
  if (n.is_array()) {
    for (const auto& e : n) JsonNumbers(e, key, out);
    return;
  }
  if (n.is_object() && n.contains("data")) return JsonNumbers(n["data"], key + ".data", out);
  if (!n.is_number()) throw KeyError{key, "must be numbers"};
  out->push_back(n.get<double>());
}

void ReadJson(const std::string& text, RawIntrinsics* raw) {
  const nlohmann::json root = nlohmann::json::parse(text);
  if (!root.is_object()) throw KeyError{"<root>", "must be an object"};
  raw->k_key = "K";
  raw->d_key = "D";
  raw->width_key = "width";
  raw->height_key = "height";
  for (const char* k : {"K", "camera_matrix"})
    if (!raw->K && root.contains(k)) {
      raw->K.emplace();
      raw->k_key = k;
      JsonNumbers(root[k], k, &*raw->K);
    }
  for (const char* k : {"D", "distortion_coefficients", "dist_coeffs"})
    if (!raw->D && root.contains(k)) {
      raw->D.emplace();
      raw->d_key = k;
      JsonNumbers(root[k], k, &*raw->D);
    }
  auto number = [&](std::initializer_list<const char*> keys, std::optional<double>* v,
                    std::string* used) {
    for (const char* k : keys) {
      if (*v || !root.contains(k)) continue;
      *used = k;
      if (!root[k].is_number()) throw KeyError{k, "must be a number"};
      *v = root[k].get<double>();
    }
  };
  number({"width", "image_width"}, &raw->width, &raw->width_key);
  number({"height", "image_height"}, &raw->height, &raw->height_key);
  if (root.contains("distortion_model")) {
    if (!root["distortion_model"].is_string())
      throw KeyError{"distortion_model", "must be a string"};
    raw->model = root["distortion_model"].get<std::string>();
  }
}

// --- common checks ---

int PixelCount(const std::optional<double>& v, const std::string& key) {
  if (!v) throw KeyError{key, "missing (the image size the intrinsics belong to)"};
  if (!(*v >= 1.0 && *v <= 65536.0) || *v != std::floor(*v))
    throw KeyError{key, "must be a whole number of pixels in [1, 65536]"};
  return static_cast<int>(*v);
}

void Finish(const RawIntrinsics& raw, CameraIntrinsics* out) {
  if (!raw.K)
    throw KeyError{raw.k_key, raw.k_key == "K" ? "missing (also accepted: camera_matrix)"
                                               : "missing (also accepted: K)"};
  const std::vector<double>& K = *raw.K;
  if (K.size() != 9)
    throw KeyError{raw.k_key,
                   "must be 3x3 (9 numbers), got " + std::to_string(K.size()) + " numbers"};
  if (K[1] != 0.0 || K[3] != 0.0 || K[6] != 0.0 || K[7] != 0.0 || K[8] != 1.0)
    throw KeyError{raw.k_key, "must be [fx 0 cx; 0 fy cy; 0 0 1] (no skew)"};
  CameraIntrinsics c;
  c.width = PixelCount(raw.width, raw.width_key);
  c.height = PixelCount(raw.height, raw.height_key);
  c.fx = K[0];
  c.cx = K[2];
  c.fy = K[4];
  c.cy = K[5];
  c.k1 = c.k2 = c.p1 = c.p2 = c.k3 = c.k4 = 0.0;
  const std::vector<double> D = raw.D ? *raw.D : std::vector<double>{};
  const std::string& model = raw.model;
  if (model == "equidistant" || model == "fisheye" || model == "kannala_brandt") {
    if (D.size() != 4)
      throw KeyError{raw.d_key,
                     model + " needs 4 numbers (k1 k2 k3 k4), got " + std::to_string(D.size())};
    c.model = DistortionModel::kKannalaBrandt;
    c.k1 = D[0];
    c.k2 = D[1];
    c.k3 = D[2];
    c.k4 = D[3];
  } else if (model.empty() || model == "plumb_bob" || model == "radtan" ||
             model == "rational_polynomial") {
    const size_t n = D.size();
    if (n != 0 && n != 4 && n != 5 && n != 8 && n != 12 && n != 14)
      throw KeyError{raw.d_key, "must have 4, 5, 8, 12 or 14 numbers (k1 k2 p1 p2 [k3 ...]), got " +
                                    std::to_string(n)};
    for (size_t i = 5; i < n; ++i)
      if (D[i] != 0.0)
        throw KeyError{raw.d_key, "coefficient " + std::to_string(i) + " (" +
                                      (i < 8 ? "rational k" + std::to_string(i - 1)
                                             : std::string("thin prism / tilt")) +
                                      ") is not 0: calibd's camera model is radial-tangential " +
                                      "(k1 k2 p1 p2 k3) or Kannala-Brandt only"};
    c.model = DistortionModel::kRadTan;
    if (n >= 4) {
      c.k1 = D[0];
      c.k2 = D[1];
      c.p1 = D[2];
      c.p2 = D[3];
    }
    if (n >= 5) c.k3 = D[4];
  } else {
    throw KeyError{"distortion_model", "'" + model +
                                           "' is not supported (plumb_bob, rational_polynomial, "
                                           "equidistant)"};
  }
  std::string why;
  if (!c.IsValid(&why)) throw KeyError{raw.k_key, why};
  *out = c;
}

}  // namespace

bool ParseIntrinsics(const std::string& text, const std::string& name, CameraIntrinsics* intrinsics,
                     std::string* error) {
  const size_t first = text.find_first_not_of(" \t\r\n");
  const bool json = first != std::string::npos && text[first] == '{';
  const bool opencv = first != std::string::npos && text.compare(first, 5, "%YAML") == 0;
  RawIntrinsics raw;
  try {
    if (json)
      ReadJson(text, &raw);
    else if (opencv)
      // OpenCV's FileStorage YAML: a %YAML:1.0 line (not YAML's own directive) before a YAML
      // document whose matrices are !!opencv-matrix maps, read here by yaml-cpp like any YAML.
      // OpenCV's own reader looped forever, threw std::length_error or asked for 80 GB on
      // malformed text (fuzz_intrinsics; tests/fuzz/corpus/intrinsics).
      ReadYaml(text.substr(std::min(text.size(), text.find('\n', first))), &raw);
    else
      ReadYaml(text, &raw);
    Finish(raw, intrinsics);
  } catch (const KeyError& e) {
    if (error) *error = name + ": " + e.key + ": " + e.what;
    return false;
  } catch (const nlohmann::json::exception& e) {
    if (error) *error = name + ": JSON syntax: " + e.what();
    return false;
  } catch (const YAML::Exception& e) {
    if (error) *error = name + ": YAML syntax: " + e.what();
    return false;
  } catch (const std::exception& e) {
    // Whatever a parser throws, the file is refused, never fatal.
    if (error) *error = name + ": cannot parse (" + e.what() + ")";
    return false;
  }
  return true;
}

bool LoadIntrinsicsFile(const std::string& path, CameraIntrinsics* intrinsics, std::string* error) {
  std::string text;
  if (!ReadWholeFile(path, &text, error)) return false;
  return ParseIntrinsics(text, path, intrinsics, error);
}

}  // namespace calibd
