#include "calibd/drivers/lidar_reference_file.hpp"

#include <cstring>

#include "calibd/core/common/validation.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "crc32.hpp"

namespace calibd {

namespace {

constexpr char kMagic[8] = {'C', 'A', 'L', 'I', 'B', 'D', 'L', 'R'};
constexpr uint32_t kVersion = 1;
constexpr uint32_t kByteOrderMark = 0x01020304u;
// Bounds far beyond any detector (M2DP of a few hundred values, a few thousand views), so that a
// corrupt count cannot ask for gigabytes.
constexpr int32_t kMaxDims = 4096;
constexpr int32_t kMaxViews = 1 << 20;

template <typename T>
void Put(std::string* out, const T& value) {
  out->append(reinterpret_cast<const char*>(&value), sizeof(value));
}

// Reads fixed-size values off the front of a byte view.
class Reader {
 public:
  explicit Reader(std::string_view bytes) : rest_(bytes) {}
  template <typename T>
  bool Take(T* value) {
    if (rest_.size() < sizeof(T)) return false;
    std::memcpy(value, rest_.data(), sizeof(T));
    rest_.remove_prefix(sizeof(T));
    return true;
  }
  bool TakeArray(void* out, size_t bytes) {
    if (rest_.size() < bytes) return false;
    if (bytes > 0) std::memcpy(out, rest_.data(), bytes);  // an empty vector's data() may be null
    rest_.remove_prefix(bytes);
    return true;
  }
  size_t left() const { return rest_.size(); }

 private:
  std::string_view rest_;
};

}  // namespace

std::string EncodeReferenceSet(const LidarReferenceSet& set) {
  std::string out(kMagic, sizeof(kMagic));
  Put(&out, kVersion);
  Put(&out, kByteOrderMark);
  Put(&out, set.key);
  Put(&out, static_cast<int32_t>(set.dims));
  Put(&out, static_cast<int32_t>(set.views.size()));
  out.append(reinterpret_cast<const char*>(set.views.data()), set.views.size() * sizeof(int32_t));
  out.append(reinterpret_cast<const char*>(set.descriptors.data()),
             set.descriptors.size() * sizeof(float));
  Put(&out, Crc32(out));
  return out;
}

bool DecodeReferenceSet(std::string_view bytes, LidarReferenceSet* set, std::string* error) {
  if (bytes.size() < sizeof(uint32_t))
    return Invalid(error,
                   "too short for a reference file (" + std::to_string(bytes.size()) + " bytes)");
  const std::string_view body = bytes.substr(0, bytes.size() - sizeof(uint32_t));
  Reader in(bytes);
  char magic[sizeof(kMagic)];
  if (!in.TakeArray(magic, sizeof(magic)) || std::memcmp(magic, kMagic, sizeof(kMagic)) != 0)
    return Invalid(error, "not a calibd reference file (no CALIBDLR magic)");
  uint32_t version = 0, mark = 0;
  if (!in.Take(&version) || version != kVersion)
    return Invalid(error, "layout version " + std::to_string(version) + ", this build reads " +
                              std::to_string(kVersion));
  if (!in.Take(&mark) || mark != kByteOrderMark)
    return Invalid(error, "written on a machine of another byte order");
  LidarReferenceSet s;
  int32_t dims = 0, count = 0;
  if (!in.Take(&s.key) || !in.Take(&dims) || !in.Take(&count))
    return Invalid(error, "truncated header");
  if (dims < 1 || dims > kMaxDims || count < 0 || count > kMaxViews)
    return Invalid(error, "implausible sizes: " + std::to_string(count) + " views of " +
                              std::to_string(dims) + " values");
  const size_t values = static_cast<size_t>(dims) * static_cast<size_t>(count);
  const size_t expected =
      sizeof(int32_t) * static_cast<size_t>(count) + sizeof(float) * values + sizeof(uint32_t);
  if (in.left() != expected)
    return Invalid(error, std::to_string(in.left()) + " bytes after the header, " +
                              std::to_string(expected) + " expected for " + std::to_string(count) +
                              " views of " + std::to_string(dims) + " values");
  s.dims = dims;
  s.views.resize(static_cast<size_t>(count));
  s.descriptors.resize(values);
  uint32_t crc = 0;
  in.TakeArray(s.views.data(), s.views.size() * sizeof(int32_t));
  in.TakeArray(s.descriptors.data(), s.descriptors.size() * sizeof(float));
  in.Take(&crc);
  if (crc != Crc32(body)) return Invalid(error, "CRC-32 mismatch (a damaged file)");
  *set = std::move(s);
  return true;
}

bool ReadReferenceFile(const std::string& path, LidarReferenceSet* set, std::string* error) {
  std::string bytes;
  if (!ReadWholeFile(path, &bytes, error)) return false;
  std::string why;
  if (!DecodeReferenceSet(bytes, set, &why)) return Invalid(error, "'" + path + "': " + why);
  return true;
}

bool WriteReferenceFile(const std::string& path, const LidarReferenceSet& set, std::string* error) {
  const auto slash = path.find_last_of('/');
  if (slash != std::string::npos && slash > 0 && !CreateDirectories(path.substr(0, slash), error))
    return false;
  return WriteFileAtomic(path, EncodeReferenceSet(set), error);
}

}  // namespace calibd
