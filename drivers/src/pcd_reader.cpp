#include "calibd/drivers/pcd_reader.hpp"

#include <lzf.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <cstring>
#include <limits>
#include <sstream>

#include "calibd/core/common/validation.hpp"
#include "calibd/drivers/atomic_file.hpp"

namespace calibd {

namespace {

struct PcdField {
  std::string name;
  int size = 4;       ///< bytes per element (SIZE)
  char type = 'F';    ///< TYPE: F float, I signed, U unsigned
  int count = 1;      ///< elements (COUNT)
  size_t offset = 0;  ///< bytes from the start of a point (binary); x points in binary_compressed
  int token = 0;      ///< index of its first value on an ascii line (padding included)
  int token_no_pad = -1;  ///< the same when padding fields are not written (-1 for padding)
  int line = 0;           ///< header line of FIELDS, for errors
};

struct PcdHeader {
  std::vector<PcdField> fields;
  size_t point_step = 0;
  int tokens = 0, tokens_no_pad = 0;
  size_t data_offset = 0;  ///< first byte after the DATA line
};

std::vector<std::string> Split(const std::string& line) {
  std::vector<std::string> out;
  std::istringstream in(line);
  std::string t;
  while (in >> t) out.push_back(t);
  return out;
}

bool ParseInt(const std::string& s, int64_t* v) {
  if (s.empty()) return false;
  char* end = nullptr;
  errno = 0;
  const long long n = std::strtoll(s.c_str(), &end, 10);
  if (*end != '\0' || errno != 0) return false;
  *v = n;
  return true;
}

// Reads one element as a double. `type`/`size` were validated with the header.
double ReadValue(const uint8_t* p, char type, int size) {
  switch (type) {
    case 'F':
      if (size == 4) {
        float f;
        std::memcpy(&f, p, 4);
        return f;
      } else {
        double d;
        std::memcpy(&d, p, 8);
        return d;
      }
    case 'I':
      switch (size) {
        case 1: {
          int8_t v;
          std::memcpy(&v, p, 1);
          return v;
        }
        case 2: {
          int16_t v;
          std::memcpy(&v, p, 2);
          return v;
        }
        case 4: {
          int32_t v;
          std::memcpy(&v, p, 4);
          return v;
        }
        default: {
          int64_t v;
          std::memcpy(&v, p, 8);
          return static_cast<double>(v);
        }
      }
    default:
      switch (size) {
        case 1:
          return p[0];
        case 2: {
          uint16_t v;
          std::memcpy(&v, p, 2);
          return v;
        }
        case 4: {
          uint32_t v;
          std::memcpy(&v, p, 4);
          return v;
        }
        default: {
          uint64_t v;
          std::memcpy(&v, p, 8);
          return static_cast<double>(v);
        }
      }
  }
}

// The header up to and including the DATA line. Errors read "<name>: line N: ...".
bool ParseHeader(const std::string& bytes, const std::string& name, const PcdReadOptions& options,
                 PcdHeader* h, PcdInfo* info, std::string* error) {
  auto fail = [&](int line, const std::string& m) {
    return Invalid(error, name + ": line " + std::to_string(line) + ": " + m);
  };
  std::vector<std::string> sizes, types, counts;
  int sizes_line = 0, types_line = 0, counts_line = 0, fields_line = 0;
  bool have_width = false, have_height = false, have_points = false;
  size_t pos = 0;
  int line_no = 0;
  while (true) {
    if (pos >= bytes.size())
      return Invalid(error, name + ": no DATA line (the header ends after line " +
                                std::to_string(line_no) + ")");
    if (pos > options.max_header_bytes)
      return Invalid(error, name + ": no DATA line within the first " +
                                std::to_string(options.max_header_bytes) + " bytes");
    size_t eol = bytes.find('\n', pos);
    const size_t next = eol == std::string::npos ? bytes.size() : eol + 1;
    if (eol == std::string::npos) eol = bytes.size();
    std::string line = bytes.substr(pos, eol - pos);
    pos = next;
    ++line_no;
    if (!line.empty() && line.back() == '\r') line.pop_back();
    const std::vector<std::string> tok = Split(line);
    if (tok.empty() || tok[0][0] == '#') continue;
    const std::string& key = tok[0];
    const std::vector<std::string> values(tok.begin() + 1, tok.end());
    if (key == "VERSION") {
      if (values.size() != 1) return fail(line_no, "VERSION needs one value");
      if (values[0] == "0.7" || values[0] == ".7")
        info->version = "0.7";
      else if (values[0] == "0.6" || values[0] == ".6")
        info->version = "0.6";
      else
        return fail(line_no, "VERSION '" + values[0] + "' is not supported (0.7 or 0.6)");
    } else if (key == "FIELDS" || key == "COLUMNS") {
      if (values.empty()) return fail(line_no, key + " lists no fields");
      fields_line = line_no;
      h->fields.clear();
      for (const auto& v : values) {
        PcdField f;
        f.name = v;
        f.line = line_no;
        h->fields.push_back(f);
      }
    } else if (key == "SIZE") {
      sizes = values;
      sizes_line = line_no;
    } else if (key == "TYPE") {
      types = values;
      types_line = line_no;
    } else if (key == "COUNT") {
      counts = values;
      counts_line = line_no;
    } else if (key == "WIDTH" || key == "HEIGHT" || key == "POINTS") {
      int64_t v = 0;
      if (values.size() != 1 || !ParseInt(values[0], &v) || v < 0)
        return fail(line_no, key + " must be one integer >= 0");
      if (key == "WIDTH") {
        info->width = v;
        have_width = true;
      } else if (key == "HEIGHT") {
        info->height = v;
        have_height = true;
      } else {
        info->points = v;
        have_points = true;
      }
    } else if (key == "VIEWPOINT") {
      if (values.size() != 7) return fail(line_no, "VIEWPOINT needs 7 numbers");
    } else if (key == "DATA") {
      if (values.size() != 1 ||
          (values[0] != "ascii" && values[0] != "binary" && values[0] != "binary_compressed"))
        return fail(line_no, "DATA must be ascii, binary or binary_compressed");
      info->data = values[0];
      h->data_offset = pos;
      break;
    } else {
      return fail(line_no, "unknown header key '" + key + "'");
    }
  }
  const int data_line = line_no;
  if (info->version.empty()) return fail(data_line, "no VERSION line before DATA");
  if (h->fields.empty()) return fail(data_line, "no FIELDS line before DATA");
  if (sizes.empty()) return fail(data_line, "no SIZE line before DATA");
  if (types.empty()) return fail(data_line, "no TYPE line before DATA");
  const size_t n = h->fields.size();
  if (sizes.size() != n)
    return fail(sizes_line, "SIZE has " + std::to_string(sizes.size()) + " entries, FIELDS (line " +
                                std::to_string(fields_line) + ") has " + std::to_string(n));
  if (types.size() != n)
    return fail(types_line, "TYPE has " + std::to_string(types.size()) + " entries, FIELDS (line " +
                                std::to_string(fields_line) + ") has " + std::to_string(n));
  if (!counts.empty() && counts.size() != n)
    return fail(counts_line, "COUNT has " + std::to_string(counts.size()) +
                                 " entries, FIELDS (line " + std::to_string(fields_line) +
                                 ") has " + std::to_string(n));
  for (size_t i = 0; i < n; ++i) {
    PcdField& f = h->fields[i];
    int64_t size = 0, count = 1;
    if (!ParseInt(sizes[i], &size))
      return fail(sizes_line, "SIZE of field '" + f.name + "' is not an integer");
    if (types[i].size() != 1 || std::string("FIU").find(types[i][0]) == std::string::npos)
      return fail(types_line, "TYPE of field '" + f.name + "' is '" + types[i] + "' (F, I or U)");
    f.type = types[i][0];
    const bool size_ok = f.type == 'F' ? (size == 4 || size == 8)
                                       : (size == 1 || size == 2 || size == 4 || size == 8);
    if (!size_ok)
      return fail(sizes_line, "field '" + f.name + "' has TYPE " + types[i] + " and SIZE " +
                                  sizes[i] + " (F takes 4 or 8, I and U 1, 2, 4 or 8)");
    f.size = static_cast<int>(size);
    if (!counts.empty() && (!ParseInt(counts[i], &count) || count < 1 || count > 65536))
      return fail(counts_line, "COUNT of field '" + f.name + "' must be an integer in [1, 65536]");
    f.count = static_cast<int>(count);
    f.offset = h->point_step;
    f.token = h->tokens;
    h->point_step += static_cast<size_t>(f.size) * static_cast<size_t>(f.count);
    h->tokens += f.count;
    if (f.name != "_") {
      f.token_no_pad = h->tokens_no_pad;
      h->tokens_no_pad += f.count;
    }
  }
  if (!have_width) return fail(data_line, "no WIDTH line before DATA");
  if (!have_height) info->height = 1;  // 0.6 writers may leave an unorganized cloud's out
  if (info->width > options.max_points || info->height > options.max_points ||
      info->width * info->height > options.max_points)
    return fail(data_line, "WIDTH " + std::to_string(info->width) + " x HEIGHT " +
                               std::to_string(info->height) + " exceeds the limit of " +
                               std::to_string(options.max_points) + " points");
  if (!have_points) info->points = info->width * info->height;
  if (info->width * info->height != info->points)
    return fail(data_line, "WIDTH*HEIGHT (" + std::to_string(info->width) + " x " +
                               std::to_string(info->height) + ") != POINTS (" +
                               std::to_string(info->points) + ")");
  for (const auto& f : h->fields) info->fields.push_back(f.name);
  return true;
}

const PcdField* FindField(const PcdHeader& h, const std::string& name) {
  for (const auto& f : h.fields)
    if (f.name == name) return &f;
  return nullptr;
}

}  // namespace

bool ParsePcd(const std::string& bytes, const std::string& name, const PcdReadOptions& options,
              lidar_frame_t* cloud, PcdInfo* info, std::string* error) {
  *info = PcdInfo{};
  PcdHeader h;
  if (!ParseHeader(bytes, name, options, &h, info, error)) return false;

  const PcdField* xyz[3] = {FindField(h, "x"), FindField(h, "y"), FindField(h, "z")};
  for (int k = 0; k < 3; ++k) {
    const char* axis = k == 0 ? "x" : k == 1 ? "y" : "z";
    if (!xyz[k])
      return Invalid(error, name + ": field '" + axis + "' is missing (FIELDS must include x y z)");
    if (xyz[k]->type != 'F')
      return Invalid(error, name + ": line " + std::to_string(xyz[k]->line) + ": field '" + axis +
                                "' has TYPE " + xyz[k]->type + " (x y z must be F: float32/64)");
    if (xyz[k]->count != 1)
      return Invalid(error, name + ": line " + std::to_string(xyz[k]->line) + ": field '" + axis +
                                "' has COUNT " + std::to_string(xyz[k]->count) + " (must be 1)");
  }
  const PcdField* intensity = FindField(h, "intensity");
  const PcdField* ring = FindField(h, "ring");
  const PcdField* time = nullptr;
  for (const char* t : {"time", "t", "timestamp"})
    if (!time) time = FindField(h, t);
  info->has_intensity = intensity != nullptr;
  info->has_ring = ring != nullptr;
  if (time) info->time_field = time->name;

  const int64_t points = info->points;
  const size_t n = static_cast<size_t>(points);
  const size_t data_bytes = n * h.point_step;
  if (data_bytes > (size_t{1} << 31))
    return Invalid(error, name + ": POINTS " + std::to_string(points) + " x point size " +
                              std::to_string(h.point_step) + " bytes exceeds 2 GiB");
  const size_t available = bytes.size() - h.data_offset;
  const auto* data = reinterpret_cast<const uint8_t*>(bytes.data()) + h.data_offset;
  std::string decompressed;
  const bool is_ascii = info->data == "ascii";
  std::vector<double> ascii;  // ascii: every value of every point, h.tokens per point
  // Where field `f`'s first element of point `i` lies (binary: array of structs; compressed:
  // struct of arrays, field by field).
  const uint8_t* base = data;
  bool soa = false;

  if (info->data == "binary") {
    if (available < data_bytes)
      return Invalid(error, name + ": binary data truncated: " + std::to_string(available) +
                                " bytes, expected " + std::to_string(data_bytes) + " (POINTS " +
                                std::to_string(points) + " x point size " +
                                std::to_string(h.point_step) + " bytes)");
    // Bytes after the last point (MATLAB's pcwrite pads the file): PCL reads the points and
    // ignores the rest; so do we, and say so.
    if (available > data_bytes) info->trailing_bytes = static_cast<int64_t>(available - data_bytes);
  } else if (info->data == "binary_compressed") {
    // PCL's layout: uint32 compressed size, uint32 uncompressed size, then the LZF stream of
    // the fields one after the other (all x, then all y, ...).
    if (available < 8)
      return Invalid(error, name +
                                ": binary_compressed data truncated: " + std::to_string(available) +
                                " bytes, the 8-byte size header is missing");
    uint32_t compressed_size = 0, uncompressed_size = 0;
    std::memcpy(&compressed_size, data, 4);
    std::memcpy(&uncompressed_size, data + 4, 4);
    if (uncompressed_size != data_bytes)
      return Invalid(error, name + ": binary_compressed uncompressed size " +
                                std::to_string(uncompressed_size) + " does not match POINTS " +
                                std::to_string(points) + " x point size " +
                                std::to_string(h.point_step) + " = " + std::to_string(data_bytes));
    if (compressed_size > available - 8)
      return Invalid(error, name + ": binary_compressed compressed size " +
                                std::to_string(compressed_size) + " exceeds the " +
                                std::to_string(available - 8) + " bytes after the size header");
    if (compressed_size < available - 8)
      return Invalid(error, name + ": binary_compressed size mismatch: " +
                                std::to_string(available - 8) + " bytes after the size header, " +
                                "the compressed size says " + std::to_string(compressed_size));
    if (data_bytes > 0) {
      if (compressed_size == 0)
        return Invalid(error, name + ": binary_compressed compressed size is 0 for " +
                                  std::to_string(data_bytes) + " bytes of points");
      decompressed.resize(data_bytes);
      const unsigned got = lzf_decompress(data + 8, compressed_size, decompressed.data(),
                                          static_cast<unsigned>(data_bytes));
      if (got != data_bytes)
        return Invalid(error, name + ": binary_compressed LZF data is corrupt or sizes lie: " +
                                  std::to_string(got) + " of " + std::to_string(data_bytes) +
                                  " bytes decompressed");
    }
    base = reinterpret_cast<const uint8_t*>(decompressed.data());
    soa = true;
  } else {
    // ascii: one point per non-empty line, values separated by blanks; padding fields `_` may
    // be written or left out (PCL leaves them out), as long as every line does the same.
    ascii.reserve(std::min(n * static_cast<size_t>(h.tokens), available));
    const char* p = bytes.data() + h.data_offset;
    const char* end = bytes.data() + bytes.size();
    // Line numbers count from the file's start, for errors.
    int line_no = static_cast<int>(std::count(
        bytes.begin(), bytes.begin() + static_cast<std::ptrdiff_t>(h.data_offset), '\n'));
    int64_t seen = 0;
    int layout = 0;  // tokens per line: h.tokens or h.tokens_no_pad, fixed by the first line
    std::vector<std::string> tok;
    while (p < end) {
      const char* eol =
          static_cast<const char*>(std::memchr(p, '\n', static_cast<size_t>(end - p)));
      if (!eol) eol = end;
      ++line_no;
      tok = Split(std::string(p, eol));
      p = eol < end ? eol + 1 : end;
      if (tok.empty()) continue;
      if (seen == points)
        return Invalid(error, name + ": line " + std::to_string(line_no) +
                                  ": more points than POINTS (" + std::to_string(points) + ")");
      const int count = static_cast<int>(tok.size());
      if (layout == 0 && (count == h.tokens || count == h.tokens_no_pad)) layout = count;
      if (count != layout)
        return Invalid(error, name + ": line " + std::to_string(line_no) + ": " +
                                  std::to_string(count) + " values, expected " +
                                  std::to_string(layout ? layout : h.tokens));
      std::vector<double> row(static_cast<size_t>(h.tokens), 0.0);
      for (const auto& f : h.fields) {
        const int first = layout == h.tokens ? f.token : f.token_no_pad;
        if (first < 0) continue;  // padding not written
        for (int e = 0; e < f.count; ++e) {
          const std::string& s = tok[static_cast<size_t>(first + e)];
          char* stop = nullptr;
          const double v = std::strtod(s.c_str(), &stop);
          if (*stop != '\0')
            return Invalid(error, name + ": line " + std::to_string(line_no) + ": '" + s +
                                      "' is not a number (field '" + f.name + "')");
          row[static_cast<size_t>(f.token + e)] = v;
        }
      }
      ascii.insert(ascii.end(), row.begin(), row.end());
      ++seen;
    }
    if (seen != points)
      return Invalid(error, name + ": ascii data truncated: " + std::to_string(seen) +
                                " points, POINTS says " + std::to_string(points));
  }

  auto value = [&](const PcdField& f, size_t i) -> double {
    if (is_ascii) return ascii[i * static_cast<size_t>(h.tokens) + static_cast<size_t>(f.token)];
    const uint8_t* p =
        soa ? base + f.offset * n + i * static_cast<size_t>(f.size) * static_cast<size_t>(f.count)
            : base + i * h.point_step + f.offset;
    return ReadValue(p, f.type, f.size);
  };

  cloud->x.clear();
  cloud->y.clear();
  cloud->z.clear();
  cloud->intensity.clear();
  cloud->ring.clear();
  cloud->time_offset_us.clear();
  cloud->x.reserve(n);
  cloud->y.reserve(n);
  cloud->z.reserve(n);
  cloud->intensity.reserve(n);
  cloud->ring.reserve(n);
  cloud->time_offset_us.reserve(n);
  std::vector<double> times;
  if (time) times.reserve(n);
  for (size_t i = 0; i < n; ++i) {
    // Checked after the conversion to float: a float64 field beyond float's range becomes inf
    // (found by fuzz_pcd).
    const float x = static_cast<float>(value(*xyz[0], i));
    const float y = static_cast<float>(value(*xyz[1], i));
    const float z = static_cast<float>(value(*xyz[2], i));
    if (!std::isfinite(x) || !std::isfinite(y) || !std::isfinite(z)) {
      ++info->nan_dropped;
      continue;
    }
    cloud->x.push_back(x);
    cloud->y.push_back(y);
    cloud->z.push_back(z);
    // Intensity is carried, not used (geometry only): a non-finite one becomes 0.
    const float power = intensity ? static_cast<float>(value(*intensity, i)) : 0.0f;
    cloud->intensity.push_back(std::isfinite(power) ? power : 0.0f);
    int16_t r = -1;
    if (ring) {
      const double v = value(*ring, i);
      // -1: no ring for this point, as lidar_frame_t says (some drivers write it for returns
      // they cannot attribute).
      if (!(v >= -1.0 && v <= 32767.0) || v != std::floor(v))
        return Invalid(error, name + ": field 'ring': point " + std::to_string(i) + " has ring " +
                                  std::to_string(v) + " (an integer in [-1, 32767] expected)");
      r = static_cast<int16_t>(v);
    }
    cloud->ring.push_back(r);
    if (time) {
      const double t = value(*time, i);
      if (!std::isfinite(t))
        return Invalid(error, name + ": field '" + time->name + "': point " + std::to_string(i) +
                                  " has a non-finite time");
      times.push_back(t);
    }
  }
  cloud->num_points = static_cast<int32_t>(cloud->x.size());
  cloud->time_offset_us.assign(cloud->x.size(), 0);
  if (time && !times.empty()) {
    // Floating-point times are seconds, integer times nanoseconds.
    const double to_us = time->type == 'F' ? 1e6 : 1e-3;
    const auto [lo, hi] = std::minmax_element(times.begin(), times.end());
    const double absolute_us = 1000.0 * 1e6;  // beyond 1000 s: a clock reading, not an offset
    double base_us = 0.0;
    if (std::max(std::abs(*lo), std::abs(*hi)) * to_us > absolute_us) {
      base_us = *lo * to_us;
      info->time_base_us = static_cast<int64_t>(std::llround(base_us));
    }
    for (size_t k = 0; k < times.size(); ++k) {
      const double us = time->type == 'F' && base_us != 0.0 ? (times[k] - *lo) * to_us
                                                            : times[k] * to_us - base_us;
      if (!(std::abs(us) <= static_cast<double>(std::numeric_limits<int32_t>::max())))
        return Invalid(error, name + ": field '" + time->name + "': point time " +
                                  std::to_string(times[k]) + " is too far from the others to be " +
                                  "an offset within one sweep");
      cloud->time_offset_us[k] = static_cast<int32_t>(std::llround(us));
    }
  }
  return true;
}

bool ReadPcdFile(const std::string& path, const PcdReadOptions& options, lidar_frame_t* cloud,
                 PcdInfo* info, std::string* error) {
  std::string bytes;
  if (!ReadWholeFile(path, &bytes, error)) return false;
  return ParsePcd(bytes, path, options, cloud, info, error);
}

}  // namespace calibd
