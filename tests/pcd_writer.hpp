#pragma once
// A small PCD writer for the tests (the reader under test is drivers/pcd_reader): any fields, each
// with its TYPE/SIZE/COUNT, in ascii, binary or binary_compressed (LZF from liblzf, the library
// the reader decompresses with; PCL writes the same layout).

#include <lzf.h>

#include <cstdint>
#include <cstring>
#include <iomanip>
#include <sstream>
#include <string>
#include <vector>

namespace calibd::testing {

struct PcdFieldSpec {
  std::string name;
  char type = 'F';  // F, I, U
  int size = 4;     // bytes
  int count = 1;
};

// Points as rows of values, one per element (sum of the fields' counts per row).
struct PcdSpec {
  std::vector<PcdFieldSpec> fields;
  std::vector<std::vector<double>> rows;
  int width = -1, height = 1;  // width -1: the number of rows
  std::string version = "0.7";
};

inline void AppendValue(double v, const PcdFieldSpec& f, std::string* out) {
  uint8_t b[8] = {};
  if (f.type == 'F') {
    if (f.size == 4) {
      const float x = static_cast<float>(v);
      std::memcpy(b, &x, 4);
    } else {
      std::memcpy(b, &v, 8);
    }
  } else if (f.type == 'I') {
    const int64_t x = static_cast<int64_t>(v);
    std::memcpy(b, &x, static_cast<size_t>(f.size));  // little-endian: the low bytes
  } else {
    const uint64_t x = static_cast<uint64_t>(v);
    std::memcpy(b, &x, static_cast<size_t>(f.size));
  }
  out->append(reinterpret_cast<const char*>(b), static_cast<size_t>(f.size));
}

inline std::string PcdHeader(const PcdSpec& s, const std::string& data) {
  std::ostringstream h;
  h << "# .PCD v" << s.version << " - Point Cloud Data file format\nVERSION " << s.version
    << "\nFIELDS";
  for (const auto& f : s.fields) h << " " << f.name;
  h << "\nSIZE";
  for (const auto& f : s.fields) h << " " << f.size;
  h << "\nTYPE";
  for (const auto& f : s.fields) h << " " << f.type;
  h << "\nCOUNT";
  for (const auto& f : s.fields) h << " " << f.count;
  const size_t n = s.rows.size();
  h << "\nWIDTH " << (s.width < 0 ? n : static_cast<size_t>(s.width)) << "\nHEIGHT " << s.height
    << "\nVIEWPOINT 0 0 0 1 0 0 0\nPOINTS " << n << "\nDATA " << data << "\n";
  return h.str();
}

// The whole file. binary_compressed: uint32 compressed size, uint32 raw size, LZF of the fields
// one after the other (struct of arrays).
inline std::string WritePcd(const PcdSpec& s, const std::string& data) {
  std::string out = PcdHeader(s, data);
  if (data == "ascii") {
    std::ostringstream body;
    body << std::setprecision(17);
    for (const auto& row : s.rows) {
      size_t k = 0;
      bool first = true;
      for (const auto& f : s.fields) {
        for (int e = 0; e < f.count; ++e, ++k) {
          if (f.name == "_") continue;  // PCL leaves padding out of ascii lines
          body << (first ? "" : " ") << row[k];
          first = false;
        }
      }
      body << "\n";
    }
    return out + body.str();
  }
  std::string raw;
  if (data == "binary") {
    for (const auto& row : s.rows) {
      size_t k = 0;
      for (const auto& f : s.fields)
        for (int e = 0; e < f.count; ++e) AppendValue(row[k++], f, &raw);
    }
    return out + raw;
  }
  size_t first = 0;
  for (const auto& f : s.fields) {
    for (const auto& row : s.rows)
      for (int e = 0; e < f.count; ++e) AppendValue(row[first + static_cast<size_t>(e)], f, &raw);
    first += static_cast<size_t>(f.count);
  }
  std::string packed(raw.size() + raw.size() / 16 + 64, '\0');
  unsigned csize = raw.empty() ? 0
                               : lzf_compress(raw.data(), static_cast<unsigned>(raw.size()),
                                              packed.data(), static_cast<unsigned>(packed.size()));
  if (!raw.empty() && csize == 0) return "";  // incompressible beyond the slack: never here
  const uint32_t sizes[2] = {csize, static_cast<uint32_t>(raw.size())};
  out.append(reinterpret_cast<const char*>(sizes), 8);
  out.append(packed.data(), csize);
  return out;
}

}  // namespace calibd::testing
