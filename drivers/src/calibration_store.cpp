#include "calibd/drivers/calibration_store.hpp"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <nlohmann/json.hpp>
#include <tuple>
#include <vector>

#include "calibd/drivers/atomic_file.hpp"
#include "crc32.hpp"

namespace calibd {

namespace {

using Json = nlohmann::ordered_json;  // keeps the fields in the order written, for people reading

constexpr const char* kFormatName = "calibd.calibration";
// 2: adds rotation_bound_deg and translation_bound_m; files of version 1 are read with both 0.
constexpr int64_t kFormatVersion = 2;
constexpr const char* kCurrentName = "current.json";
constexpr const char* kReferenceName = "reference.json";
constexpr const char* kHistoryDir = "history";
constexpr size_t kMaxTextField = 256;
// A calibration file is ~1 kB; anything far larger is not one, and is not read into memory.
constexpr off_t kMaxFileBytes = 1 << 20;
constexpr int kMaxKeepPrevious = 1000;

std::string SysError(const std::string& what, const std::string& path, int err) {
  return what + " '" + path + "': " + std::strerror(err);
}

// history/v000007.json: fixed width so that names sort like versions; only this exact spelling
// is a history file (no two names for one version).
std::string HistoryName(int64_t version) {
  char name[40];
  std::snprintf(name, sizeof(name), "v%06lld.json", static_cast<long long>(version));
  return name;
}

bool ParseHistoryName(const std::string& name, int64_t* version) {
  if (name.size() < 7 || name[0] != 'v' || name.compare(name.size() - 5, 5, ".json") != 0)
    return false;
  const std::string digits = name.substr(1, name.size() - 6);
  if (digits.empty() || digits.size() > 18) return false;
  for (const char ch : digits)
    if (ch < '0' || ch > '9') return false;
  const int64_t v = std::stoll(digits);
  if (v < 1 || HistoryName(v) != name) return false;
  *version = v;
  return true;
}

bool IsPrintableAscii(const std::string& s) {
  for (const char ch : s)
    if (ch < 0x20 || ch > 0x7e) return false;
  return true;
}

// The text the checksum covers: every field, written by this file rather than by the JSON
// library, so a library upgrade that spells numbers differently cannot invalidate stored files.
// Doubles as their IEEE-754 bit patterns (exact), strings length-prefixed (unambiguous). The
// fields of `format_version` (a file keeps the checksum its own version wrote).
std::string CanonicalText(const StoredCalibration& c, int64_t format_version = kFormatVersion) {
  std::string out = std::string(kFormatName) + "/" + std::to_string(format_version) + "\n";
  auto add_int = [&](const char* key, int64_t v) {
    out += key;
    out += '=';
    out += std::to_string(v);
    out += '\n';
  };
  auto add_double = [&](const char* key, double v) {
    uint64_t bits = 0;
    std::memcpy(&bits, &v, sizeof(bits));
    char hex[17];
    std::snprintf(hex, sizeof(hex), "%016llx", static_cast<unsigned long long>(bits));
    out += key;
    out += '=';
    out += hex;
    out += '\n';
  };
  auto add_string = [&](const char* key, const std::string& v) {
    out += key;
    out += '=';
    out += std::to_string(v.size());
    out += ':';
    out += v;
    out += '\n';
  };
  add_int("version", c.version);
  add_int("replaced_version", c.replaced_version);
  add_int("created_unix_s", c.created_unix_s);
  add_int("verified_unix_s", c.verified_unix_s);
  for (int r = 0; r < 4; ++r)
    for (int col = 0; col < 4; ++col)
      add_double("T_camera_lidar", c.T_camera_lidar.matrix()(r, col));
  add_string("lidar_serial", c.lidar_serial);
  add_string("camera_serial", c.camera_serial);
  add_string("source", c.source);
  add_string("verdict", c.verdict);
  add_double("reprojection_mean_px", c.reprojection_mean_px);
  add_double("residual_rms_m", c.residual_rms_m);
  add_double("rotation_sigma_deg", c.rotation_sigma_deg);
  add_double("translation_sigma_m", c.translation_sigma_m);
  add_int("frames_used", c.frames_used);
  add_int("boards_used", c.boards_used);
  add_double("delta_rotation_deg", c.delta_rotation_deg);
  add_double("delta_translation_m", c.delta_translation_m);
  if (format_version >= 2) {
    add_double("rotation_bound_deg", c.rotation_bound_deg);
    add_double("translation_bound_m", c.translation_bound_m);
  }
  return out;
}

std::string Crc32Hex(const std::string& text) {
  char hex[9];
  std::snprintf(hex, sizeof(hex), "%08lx", static_cast<unsigned long>(Crc32(text)));
  return hex;
}

bool SameCalibration(const StoredCalibration& a, const StoredCalibration& b) {
  return CanonicalText(a) == CanonicalText(b);
}

std::string ToFileText(const StoredCalibration& c) {
  Json T = Json::array();
  for (int r = 0; r < 4; ++r) {
    Json row = Json::array();
    for (int col = 0; col < 4; ++col) row.push_back(c.T_camera_lidar.matrix()(r, col));
    T.push_back(row);
  }
  Json body;
  body["version"] = c.version;
  body["replaced_version"] = c.replaced_version;
  body["created_unix_s"] = c.created_unix_s;
  body["verified_unix_s"] = c.verified_unix_s;
  body["T_camera_lidar"] = T;
  body["lidar_serial"] = c.lidar_serial;
  body["camera_serial"] = c.camera_serial;
  body["source"] = c.source;
  body["verdict"] = c.verdict;
  body["reprojection_mean_px"] = c.reprojection_mean_px;
  body["residual_rms_m"] = c.residual_rms_m;
  body["rotation_sigma_deg"] = c.rotation_sigma_deg;
  body["translation_sigma_m"] = c.translation_sigma_m;
  body["frames_used"] = c.frames_used;
  body["boards_used"] = c.boards_used;
  body["delta_rotation_deg"] = c.delta_rotation_deg;
  body["delta_translation_m"] = c.delta_translation_m;
  body["rotation_bound_deg"] = c.rotation_bound_deg;
  body["translation_bound_m"] = c.translation_bound_m;
  Json file;
  file["format"] = kFormatName;
  file["format_version"] = kFormatVersion;
  file["calibration"] = body;
  file["crc32"] = Crc32Hex(CanonicalText(c));
  // Strings were checked to be printable ASCII (IsValid), so dump() cannot throw on bad UTF-8.
  return file.dump(2) + "\n";
}

// Thrown only inside this file, to carry what is wrong with a stored file up to FromFileText.
struct FileError {
  std::string what;
};

const Json& Field(const Json& object, const char* key) {
  const auto it = object.find(key);
  if (it == object.end()) throw FileError{std::string("field '") + key + "' is missing"};
  return *it;
}

int64_t GetInt(const Json& object, const char* key) {
  const Json& v = Field(object, key);
  if (!v.is_number_integer()) throw FileError{std::string("field '") + key + "' is not an integer"};
  return v.get<int64_t>();
}

double GetDouble(const Json& object, const char* key) {
  const Json& v = Field(object, key);
  if (!v.is_number()) throw FileError{std::string("field '") + key + "' is not a number"};
  return v.get<double>();
}

std::string GetString(const Json& object, const char* key) {
  const Json& v = Field(object, key);
  if (!v.is_string()) throw FileError{std::string("field '") + key + "' is not a string"};
  return v.get<std::string>();
}

int GetSmallInt(const Json& object, const char* key) {
  const int64_t v = GetInt(object, key);
  if (v < 0 || v > 1000000000) throw FileError{std::string("field '") + key + "' is out of range"};
  return static_cast<int>(v);
}

void CheckKeys(const Json& object, const std::vector<const char*>& known, const char* where) {
  for (const auto& kv : object.items()) {
    bool ok = false;
    for (const char* k : known) ok = ok || kv.key() == k;
    if (!ok) throw FileError{std::string("unexpected field '") + kv.key() + "' in " + where};
  }
}

void ParseOrThrow(const std::string& text, StoredCalibration* out) {
  Json file;
  try {
    file = Json::parse(text);
  } catch (const Json::parse_error& e) {
    throw FileError{"not valid JSON at byte " + std::to_string(e.byte) +
                    " (file corrupt or truncated)"};
  } catch (const Json::exception& e) {
    // E.g. out_of_range 406: a number beyond double's range (found by fuzz_calibration_store).
    throw FileError{std::string("not valid JSON (file corrupt): ") + e.what()};
  }
  if (!file.is_object()) throw FileError{"not a JSON object (file corrupt)"};
  if (GetString(file, "format") != kFormatName)
    throw FileError{std::string("not a calibration file (format is not '") + kFormatName + "')"};
  const int64_t format_version = GetInt(file, "format_version");
  if (format_version > kFormatVersion)
    throw FileError{"format version " + std::to_string(format_version) +
                    " is newer than this calibd reads (" + std::to_string(kFormatVersion) +
                    "): written by a later release"};
  if (format_version < 1)
    throw FileError{"format version " + std::to_string(format_version) + " is not valid"};
  CheckKeys(file, {"format", "format_version", "calibration", "crc32"}, "the file");
  const Json& body = Field(file, "calibration");
  if (!body.is_object()) throw FileError{"field 'calibration' is not an object"};
  std::vector<const char*> keys = {"version",
                                   "replaced_version",
                                   "created_unix_s",
                                   "verified_unix_s",
                                   "T_camera_lidar",
                                   "lidar_serial",
                                   "camera_serial",
                                   "source",
                                   "verdict",
                                   "reprojection_mean_px",
                                   "residual_rms_m",
                                   "rotation_sigma_deg",
                                   "translation_sigma_m",
                                   "frames_used",
                                   "boards_used",
                                   "delta_rotation_deg",
                                   "delta_translation_m"};
  if (format_version >= 2) keys.insert(keys.end(), {"rotation_bound_deg", "translation_bound_m"});
  CheckKeys(body, keys, "'calibration'");
  StoredCalibration c;
  c.version = GetInt(body, "version");
  c.replaced_version = GetInt(body, "replaced_version");
  c.created_unix_s = GetInt(body, "created_unix_s");
  c.verified_unix_s = GetInt(body, "verified_unix_s");
  const Json& T = Field(body, "T_camera_lidar");
  if (!T.is_array() || T.size() != 4) throw FileError{"field 'T_camera_lidar' is not 4 rows"};
  for (size_t r = 0; r < 4; ++r) {
    if (!T[r].is_array() || T[r].size() != 4)
      throw FileError{"field 'T_camera_lidar' row " + std::to_string(r) + " is not 4 numbers"};
    for (size_t col = 0; col < 4; ++col) {
      if (!T[r][col].is_number()) throw FileError{"field 'T_camera_lidar' holds a non-number"};
      c.T_camera_lidar.matrix()(static_cast<Eigen::Index>(r), static_cast<Eigen::Index>(col)) =
          T[r][col].get<double>();
    }
  }
  c.lidar_serial = GetString(body, "lidar_serial");
  c.camera_serial = GetString(body, "camera_serial");
  c.source = GetString(body, "source");
  c.verdict = GetString(body, "verdict");
  c.reprojection_mean_px = GetDouble(body, "reprojection_mean_px");
  c.residual_rms_m = GetDouble(body, "residual_rms_m");
  c.rotation_sigma_deg = GetDouble(body, "rotation_sigma_deg");
  c.translation_sigma_m = GetDouble(body, "translation_sigma_m");
  c.frames_used = GetSmallInt(body, "frames_used");
  c.boards_used = GetSmallInt(body, "boards_used");
  c.delta_rotation_deg = GetDouble(body, "delta_rotation_deg");
  c.delta_translation_m = GetDouble(body, "delta_translation_m");
  if (format_version >= 2) {
    c.rotation_bound_deg = GetDouble(body, "rotation_bound_deg");
    c.translation_bound_m = GetDouble(body, "translation_bound_m");
  }
  if (GetString(file, "crc32") != Crc32Hex(CanonicalText(c, format_version)))
    throw FileError{"checksum mismatch (file corrupt or truncated)"};
  // The checksum matched, so what follows can only be a file written by a faulty writer.
  std::string why;
  if (!c.IsValid(&why)) throw FileError{"invalid content: " + why};
  if (c.version < 1 || c.replaced_version < 0 || c.replaced_version >= c.version)
    throw FileError{"invalid content: version " + std::to_string(c.version) +
                    " / replaced_version " + std::to_string(c.replaced_version)};
  if (!std::isfinite(c.delta_rotation_deg) || !std::isfinite(c.delta_translation_m))
    throw FileError{"invalid content: non-finite delta"};
  *out = c;
}

}  // namespace

bool ParseCalibrationFile(const std::string& text, StoredCalibration* c, std::string* error) {
  try {
    ParseOrThrow(text, c);
  } catch (const FileError& e) {
    if (error) *error = e.what;
    return false;
  }
  return true;
}

namespace {

enum class LoadStatus { kOk, kMissing, kBad };

// Reads one stored calibration; `why` says what is wrong when it is not kOk.
LoadStatus LoadFile(const std::string& path, StoredCalibration* c, std::string* why) {
  struct stat st {};
  if (::stat(path.c_str(), &st) != 0) {
    if (errno == ENOENT) {
      *why = "missing";
      return LoadStatus::kMissing;
    }
    *why = SysError("cannot stat", path, errno);
    return LoadStatus::kBad;
  }
  if (!S_ISREG(st.st_mode)) {
    *why = "not a regular file";
    return LoadStatus::kBad;
  }
  if (st.st_size > kMaxFileBytes) {
    *why = "larger than 1 MiB, not a calibration file";
    return LoadStatus::kBad;
  }
  std::string text;
  if (!ReadWholeFile(path, &text, why)) return LoadStatus::kBad;
  return ParseCalibrationFile(text, c, why) ? LoadStatus::kOk : LoadStatus::kBad;
}

bool WriteCalibrationFile(const std::string& path, const StoredCalibration& c, std::string* error) {
  return WriteFileAtomic(path, ToFileText(c), error);
}

std::string ParentOf(const std::string& path) {
  const auto slash = path.find_last_of('/');
  if (slash == std::string::npos) return ".";
  if (slash == 0) return "/";
  return path.substr(0, slash);
}

// fsync of a directory makes the entries created or removed in it durable.
bool SyncDirectory(const std::string& dir, std::string* error) {
  const int fd = ::open(dir.c_str(), O_RDONLY | O_DIRECTORY | O_CLOEXEC);
  if (fd < 0) {
    if (error) *error = SysError("cannot open directory", dir, errno);
    return false;
  }
  const bool ok = ::fsync(fd) == 0;
  const int err = errno;
  ::close(fd);
  if (!ok && error) *error = SysError("cannot fsync directory", dir, err);
  return ok;
}

bool EnsureDirectory(const std::string& dir, std::string* error) {
  struct stat st {};
  if (::stat(dir.c_str(), &st) == 0) {
    if (S_ISDIR(st.st_mode)) return true;
    if (error) *error = "'" + dir + "' exists and is not a directory";
    return false;
  }
  if (errno != ENOENT) {
    if (error) *error = SysError("cannot stat", dir, errno);
    return false;
  }
  // 0700: calibrations are the agent's, no other user reads or writes them.
  if (::mkdir(dir.c_str(), 0700) != 0) {
    if (error) *error = SysError("cannot create directory", dir, errno);
    return false;
  }
  return SyncDirectory(ParentOf(dir), error);
}

bool RemoveFile(const std::string& path, std::string* error) {
  if (::unlink(path.c_str()) != 0) {
    if (error) *error = SysError("cannot remove", path, errno);
    return false;
  }
  return SyncDirectory(ParentOf(path), error);
}

// Versions are ordered by number; a copy of the same version verified later is newer.
std::tuple<int64_t, int64_t> Recency(const StoredCalibration& c) {
  return {c.version, c.verified_unix_s};
}

// The store's own fields of a calibration that replaces `previous` (nullptr: replaces nothing).
void Stamp(const StoredCalibration* previous, int64_t version, StoredCalibration* c) {
  c->version = version;
  c->replaced_version = previous ? previous->version : 0;
  c->delta_rotation_deg = 0.0;
  c->delta_translation_m = 0.0;
  if (previous) {
    c->delta_rotation_deg =
        RotationAngle(previous->T_camera_lidar.linear(), c->T_camera_lidar.linear()) * kRad2Deg;
    c->delta_translation_m =
        (c->T_camera_lidar.translation() - previous->T_camera_lidar.translation()).norm();
  }
}

bool StartsWith(const std::string& s, const std::string& prefix) {
  return s.compare(0, prefix.size(), prefix) == 0;
}

}  // namespace

bool StoredCalibration::IsValid(std::string* error) const {
  auto fail = [&](const std::string& key, const std::string& what) {
    if (error) *error = key + ": " + what;
    return false;
  };
  if (!T_camera_lidar.matrix().allFinite()) return fail("T_camera_lidar", "must be finite");
  const Eigen::Matrix3d R = T_camera_lidar.linear();
  if (!(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || !(R.determinant() > 0.0))
    return fail("T_camera_lidar", "rotation part is not a proper rotation");
  if (T_camera_lidar.matrix().row(3) != Eigen::RowVector4d(0.0, 0.0, 0.0, 1.0))
    return fail("T_camera_lidar", "last row must be [0, 0, 0, 1]");
  const std::pair<const char*, const std::string*> texts[] = {{"lidar_serial", &lidar_serial},
                                                              {"camera_serial", &camera_serial},
                                                              {"source", &source},
                                                              {"verdict", &verdict}};
  for (const auto& [key, value] : texts) {
    if (value->empty()) return fail(key, "must not be empty");
    if (value->size() > kMaxTextField)
      return fail(key, "longer than " + std::to_string(kMaxTextField) + " characters");
    if (!IsPrintableAscii(*value)) return fail(key, "must be printable ASCII");
  }
  if (verdict == "rejected") return fail("verdict", "a rejected calibration is never stored");
  if (created_unix_s < 0) return fail("created_unix_s", "must be >= 0");
  if (verified_unix_s < 0) return fail("verified_unix_s", "must be >= 0");
  const std::pair<const char*, double> figures[] = {
      {"reprojection_mean_px", reprojection_mean_px}, {"residual_rms_m", residual_rms_m},
      {"rotation_sigma_deg", rotation_sigma_deg},     {"translation_sigma_m", translation_sigma_m},
      {"rotation_bound_deg", rotation_bound_deg},     {"translation_bound_m", translation_bound_m}};
  for (const auto& [key, value] : figures)
    if (!std::isfinite(value) || value < 0.0) return fail(key, "must be finite and >= 0");
  if (frames_used < 0) return fail("frames_used", "must be >= 0");
  if (boards_used < 0) return fail("boards_used", "must be >= 0");
  return true;
}

bool CalibrationStoreConfig::IsValid(std::string* error) const {
  auto fail = [&](const std::string& key, const std::string& what) {
    if (error) *error = key + ": " + what;
    return false;
  };
  if (directory.empty()) return fail("directory", "must not be empty");
  if (keep_previous < 0)
    return fail("keep_previous", "must be >= 0 (got " + std::to_string(keep_previous) + ")");
  if (keep_previous > kMaxKeepPrevious)
    return fail("keep_previous", "must be <= " + std::to_string(kMaxKeepPrevious) + " (got " +
                                     std::to_string(keep_previous) + ")");
  return true;
}

bool CalibrationStore::Open(const CalibrationStoreConfig& config, std::string* error) {
  *this = CalibrationStore();
  if (!config.IsValid(error)) return false;
  config_ = config;
  while (config_.directory.size() > 1 && config_.directory.back() == '/')
    config_.directory.pop_back();
  if (!EnsureDirectory(config_.directory, error)) return false;
  if (!EnsureDirectory(PathOf(kHistoryDir), error)) return false;

  struct Copy {
    std::string name;  // relative to the store directory, for messages
    StoredCalibration c;
  };
  std::vector<Copy> valid;  // history files that passed every check
  int64_t max_version = 0;  // over every history name and valid file: never reused
  bool any_history_file = false;
  std::error_code ec;
  for (std::filesystem::directory_iterator it(PathOf(kHistoryDir), ec), end; !ec && it != end;
       it.increment(ec)) {
    const std::string file_name = it->path().filename().string();
    int64_t version = 0;
    if (!ParseHistoryName(file_name, &version)) continue;  // temp files of interrupted writes
    any_history_file = true;
    max_version = std::max(max_version, version);
    const std::string name = std::string(kHistoryDir) + "/" + file_name;
    StoredCalibration c;
    std::string why;
    if (LoadFile(PathOf(name), &c, &why) != LoadStatus::kOk) {
      load_warnings_.push_back(name + ": " + why + ": skipped");
      continue;
    }
    if (c.version != version) {
      load_warnings_.push_back(name + ": holds version " + std::to_string(c.version) +
                               ", not the one in its name: skipped");
      max_version = std::max(max_version, c.version);
      continue;
    }
    valid.push_back({name, c});
  }
  if (ec) {
    if (error) *error = SysError("cannot list", PathOf(kHistoryDir), ec.value());
    *this = CalibrationStore();
    return false;
  }
  std::sort(valid.begin(), valid.end(),
            [](const Copy& a, const Copy& b) { return Recency(a.c) > Recency(b.c); });

  StoredCalibration from_current_file;
  std::string current_why;
  const LoadStatus current_status =
      LoadFile(PathOf(kCurrentName), &from_current_file, &current_why);
  const bool current_file_ok = current_status == LoadStatus::kOk;
  if (current_file_ok) max_version = std::max(max_version, from_current_file.version);
  const Copy* newest = valid.empty() ? nullptr : &valid.front();
  if (current_file_ok && (!newest || Recency(from_current_file) >= Recency(newest->c))) {
    current_ = from_current_file;
    has_current_ = true;
  } else if (newest) {
    current_ = newest->c;
    has_current_ = true;
    const std::string using_newest =
        "using version " + std::to_string(newest->c.version) + " from " + newest->name;
    if (!current_file_ok) {
      load_warnings_.push_back(std::string(kCurrentName) + ": " + current_why + ", " +
                               using_newest);
    } else if (from_current_file.version < newest->c.version) {
      load_warnings_.push_back(std::string(kCurrentName) + ": holds version " +
                               std::to_string(from_current_file.version) +
                               ", older than the history (a commit was interrupted before " +
                               kCurrentName + " was replaced), " + using_newest);
    } else {
      load_warnings_.push_back(std::string(kCurrentName) +
                               ": an older verification time than the history (an update was "
                               "interrupted), " +
                               using_newest);
    }
  } else if (current_status == LoadStatus::kBad || any_history_file) {
    load_warnings_.push_back(std::string(kCurrentName) + ": " + current_why +
                             ", and no valid version in " + kHistoryDir +
                             "/: no current calibration");
  }

  for (const Copy& copy : valid) {
    if (has_current_ && SameCalibration(copy.c, current_)) current_in_history_ = true;
    if (has_current_ && copy.c.version < current_.version &&
        history_.size() < static_cast<size_t>(config_.keep_previous))
      history_.push_back(copy.c);
  }

  std::string why;
  const LoadStatus reference_status = LoadFile(PathOf(kReferenceName), &reference_, &why);
  has_reference_ = reference_status == LoadStatus::kOk;
  if (has_reference_) max_version = std::max(max_version, reference_.version);
  if (reference_status == LoadStatus::kBad)
    load_warnings_.push_back(std::string(kReferenceName) + ": " + why + ": no reference");
  if (!has_reference_) reference_ = StoredCalibration();

  next_version_ = max_version + 1;
  open_ = true;
  return true;
}

bool CalibrationStore::Commit(const StoredCalibration& c, std::string* error) {
  if (!open_) {
    if (error) *error = "calibration store not open";
    return false;
  }
  std::string why;
  if (!c.IsValid(&why)) {
    if (error) *error = "calibration not stored: " + why;
    return false;
  }
  StoredCalibration next = c;
  Stamp(has_current_ ? &current_ : nullptr, next_version_, &next);

  // The old current must survive current.json being replaced: make sure history/ holds it.
  if (has_current_ && !current_in_history_) {
    if (!WriteCalibrationFile(
            PathOf(std::string(kHistoryDir) + "/" + HistoryName(current_.version)), current_,
            error))
      return false;
    current_in_history_ = true;  // true on disk whatever happens next
  }
  // Write order: history first, then current.json (see the header for the crash analysis).
  const std::string history_path =
      PathOf(std::string(kHistoryDir) + "/" + HistoryName(next.version));
  if (!WriteCalibrationFile(history_path, next, error)) return false;
  if (!WriteCalibrationFile(PathOf(kCurrentName), next, &why)) {
    std::string undo;
    if (RemoveFile(history_path, &undo)) {
      why += " (nothing changed)";
    } else {
      why += "; and " + undo + ": version " + std::to_string(next.version) +
             " will be taken as current on the next load";
    }
    if (error) *error = why;
    return false;
  }

  if (has_current_) history_.insert(history_.begin(), current_);
  if (history_.size() > static_cast<size_t>(config_.keep_previous))
    history_.resize(static_cast<size_t>(config_.keep_previous));
  current_ = next;
  has_current_ = true;
  current_in_history_ = true;
  ++next_version_;
  Trim();
  return true;
}

bool CalibrationStore::MarkVerified(int64_t unix_s, std::string* error) {
  if (!open_ || !has_current_) {
    if (error) *error = open_ ? "no current calibration to mark verified" : "store not open";
    return false;
  }
  if (unix_s < 0) {
    if (error) *error = "verified time: must be >= 0 (got " + std::to_string(unix_s) + ")";
    return false;
  }
  StoredCalibration updated = current_;
  updated.verified_unix_s = unix_s;
  // current.json first: after a crash in between it is the newer copy, which load prefers.
  if (!WriteCalibrationFile(PathOf(kCurrentName), updated, error)) return false;
  const std::string history_path =
      PathOf(std::string(kHistoryDir) + "/" + HistoryName(updated.version));
  std::string why;
  if (!WriteCalibrationFile(history_path, updated, &why)) {
    std::string undo;
    if (WriteCalibrationFile(PathOf(kCurrentName), current_, &undo)) {
      why += " (nothing changed)";
    } else {
      why += "; and " + undo + ": " + kCurrentName + " keeps the new verification time";
    }
    if (error) *error = why;
    return false;
  }
  current_ = updated;
  current_in_history_ = true;
  return true;
}

bool CalibrationStore::SetReference(const StoredCalibration& c, std::string* error) {
  if (!open_) {
    if (error) *error = "calibration store not open";
    return false;
  }
  std::string why;
  if (!c.IsValid(&why)) {
    if (error) *error = "reference not stored: " + why;
    return false;
  }
  StoredCalibration reference = c;
  Stamp(has_reference_ ? &reference_ : nullptr, next_version_, &reference);
  if (!WriteCalibrationFile(PathOf(kReferenceName), reference, error)) return false;
  reference_ = reference;
  has_reference_ = true;
  ++next_version_;
  return true;
}

bool CalibrationStore::RestoreReference(int64_t unix_s, std::string* error) {
  if (!open_ || !has_reference_) {
    if (error) *error = open_ ? "no reference calibration to restore" : "store not open";
    return false;
  }
  if (has_current_ && (reference_.lidar_serial != current_.lidar_serial ||
                       reference_.camera_serial != current_.camera_serial)) {
    if (error)
      *error = "reference is for lidar '" + reference_.lidar_serial + "' / camera '" +
               reference_.camera_serial + "' but the current calibration is for lidar '" +
               current_.lidar_serial + "' / camera '" + current_.camera_serial + "'";
    return false;
  }
  StoredCalibration restored = reference_;
  restored.created_unix_s = unix_s;
  restored.verified_unix_s = 0;
  restored.verdict = "restored_reference";
  return Commit(restored, error);
}

void CalibrationStore::Trim() {
  const int64_t oldest_kept = history_.empty() ? current_.version : history_.back().version;
  for (const char* dir : {".", kHistoryDir}) {
    const std::string dir_path = PathOf(dir);
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dir_path, ec), end; !ec && it != end;
         it.increment(ec)) {
      const std::string name = it->path().filename().string();
      int64_t version = 0;
      const bool old_version =
          dir != std::string(".") && ParseHistoryName(name, &version) && version < oldest_kept;
      // WriteFileAtomic's temp files are "<target>.tmp.<pid>"; one is left per interrupted write.
      const bool leftover = name.find(".json.tmp.") != std::string::npos &&
                            (StartsWith(name, "v") || StartsWith(name, kCurrentName) ||
                             StartsWith(name, kReferenceName));
      if (old_version || leftover) ::unlink((dir_path + "/" + name).c_str());
    }
  }
}

}  // namespace calibd
