#include "calibd/drivers/recorded_folder.hpp"

#include <png.h>
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cstdlib>
#include <filesystem>
#include <map>
#include <sstream>

#include "calibd/core/common/validation.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "jpeg_decoder.hpp"

namespace calibd {

namespace fs = std::filesystem;

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

bool IsImage(const std::string& ext) { return ext == ".png" || ext == ".jpg" || ext == ".jpeg"; }

bool IsNumber(const std::string& s) {
  return !s.empty() && s.size() < 19 &&
         std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

// Stem order: numeric when both are numbers (9 before 10), else by text.
bool StemLess(const std::string& a, const std::string& b) {
  if (IsNumber(a) && IsNumber(b)) {
    const long long x = std::stoll(a), y = std::stoll(b);
    if (x != y) return x < y;
  }
  return a < b;
}

std::string Trim(const std::string& s) {
  const size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  const size_t e = s.find_last_not_of(" \t\r");
  return s.substr(b, e - b + 1);
}

bool ReadCsv(const std::string& dir, const fs::path& csv, const RecordedFolderOptions& options,
             RecordedFolder* folder, std::string* error) {
  std::string text;
  if (!ReadWholeFile(csv.string(), &text, error)) return false;
  std::istringstream in(text);
  std::string line;
  int line_no = 0;
  bool header = false;
  std::vector<std::pair<int64_t, RecordedEntry>> keyed;  // delivery time, entry
  while (std::getline(in, line)) {
    ++line_no;
    line = Trim(line);
    if (line.empty() || line[0] == '#') continue;
    const std::string where = csv.string() + ": line " + std::to_string(line_no) + ": ";
    std::vector<std::string> cols;
    std::stringstream ls(line);
    std::string col;
    while (std::getline(ls, col, ',')) cols.push_back(Trim(col));
    if (!header) {
      if (cols != std::vector<std::string>{"time_us", "sensor", "file"})
        return Invalid(error,
                       where + "the header must be `time_us,sensor,file` (got `" + line + "`)");
      header = true;
      continue;
    }
    if (cols.size() != 3)
      return Invalid(error, where + std::to_string(cols.size()) +
                                " columns, expected 3 (time_us,sensor,file)");
    char* end = nullptr;
    errno = 0;
    const long long t = std::strtoll(cols[0].c_str(), &end, 10);
    if (cols[0].empty() || *end != '\0' || errno != 0)
      return Invalid(error, where + "time_us '" + cols[0] + "' is not an integer (microseconds)");
    RecordedEntry e;
    e.utime = t;
    if (cols[1] == "lidar")
      e.sensor = RecordedEntry::Sensor::kLidar;
    else if (cols[1] == "camera")
      e.sensor = RecordedEntry::Sensor::kCamera;
    else
      return Invalid(error, where + "sensor must be lidar or camera (got '" + cols[1] + "')");
    if (cols[2].empty()) return Invalid(error, where + "file is empty");
    e.path = (fs::path(dir) / cols[2]).string();
    std::error_code ec;
    if (!fs::is_regular_file(e.path, ec))
      return Invalid(error, where + "file '" + cols[2] + "' does not exist in " + dir);
    const int64_t delivered = e.sensor == RecordedEntry::Sensor::kLidar ? t + options.sweep_us : t;
    keyed.emplace_back(delivered, std::move(e));
  }
  if (!header)
    return Invalid(error, csv.string() + ": empty (header `time_us,sensor,file` expected)");
  if (keyed.empty()) return Invalid(error, csv.string() + ": lists no files");
  // Delivery order; at equal times the camera first (it waits for its sweep).
  std::stable_sort(keyed.begin(), keyed.end(), [](const auto& a, const auto& b) {
    if (a.first != b.first) return a.first < b.first;
    return a.second.sensor == RecordedEntry::Sensor::kCamera &&
           b.second.sensor == RecordedEntry::Sensor::kLidar;
  });
  for (auto& k : keyed) folder->entries.push_back(std::move(k.second));
  folder->timed = true;
  return true;
}

}  // namespace

bool ScanRecordedFolder(const std::string& dir, const RecordedFolderOptions& options,
                        RecordedFolder* folder, std::string* error) {
  *folder = RecordedFolder{};
  std::error_code ec;
  if (!fs::is_directory(dir, ec))
    return Invalid(error, "folder '" + dir + "' does not exist or is not a directory");
  const fs::path csv = fs::path(dir) / "frames.csv";
  if (fs::exists(csv, ec)) return ReadCsv(dir, csv, options, folder, error);

  std::map<std::string, std::string> clouds, images;  // stem -> path
  for (fs::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
    if (!it->is_regular_file(ec)) continue;
    const fs::path& p = it->path();
    const std::string ext = Lower(p.extension().string());
    const std::string stem = p.stem().string();
    auto& into = ext == ".pcd" ? clouds : images;
    if (ext != ".pcd" && !IsImage(ext)) continue;
    if (!into.emplace(stem, p.string()).second)
      return Invalid(error, "folder '" + dir + "': two " + (ext == ".pcd" ? "clouds" : "images") +
                                " with the stem '" + stem + "' (" + into[stem] + ", " + p.string() +
                                ")");
  }
  if (ec) return Invalid(error, "folder '" + dir + "': cannot list it: " + ec.message());
  std::vector<std::string> stems;
  for (const auto& [stem, path] : clouds) {
    if (images.count(stem))
      stems.push_back(stem);
    else
      ++folder->unmatched_clouds;
  }
  folder->unmatched_images = static_cast<int>(images.size() - stems.size());
  if (stems.empty())
    return Invalid(
        error, "folder '" + dir + "': no frames: no frames.csv and no .pcd file with an " +
                   "image of the same name stem (.png, .jpg) (" + std::to_string(clouds.size()) +
                   " clouds, " + std::to_string(images.size()) + " images)");
  std::sort(stems.begin(), stems.end(), StemLess);
  for (size_t k = 0; k < stems.size(); ++k) {
    const int64_t t = static_cast<int64_t>(k + 1) * options.stem_spacing_us;
    folder->entries.push_back({RecordedEntry::Sensor::kCamera, t, images[stems[k]]});
    folder->entries.push_back({RecordedEntry::Sensor::kLidar, t, clouds[stems[k]]});
  }
  return true;
}

namespace {

// No camera frame is near this (3840x1920 is 7.4 MP); a few hundred bytes of JPEG or PNG can
// declare 500 MP, which OpenCV (its limit is 2^30 pixels) would decode into half a gigabyte:
// found by fuzz_recorded_image, the header is read first.
constexpr int64_t kMaxImagePixels = 100'000'000;

// The PNG signature (ISO/IEC 15948 §5.2).
bool IsPng(const std::string& bytes) {
  static const uint8_t kPng[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n'};
  return bytes.size() >= 8 &&
         std::equal(kPng, kPng + 8, reinterpret_cast<const uint8_t*>(bytes.data()));
}

// JPEG's SOI marker and the first marker after it (ITU T.81 §B.1.1.3).
bool IsJpeg(const std::string& bytes) {
  const auto* b = reinterpret_cast<const uint8_t*>(bytes.data());
  return bytes.size() >= 3 && b[0] == 0xFF && b[1] == 0xD8 && b[2] == 0xFF;
}

// The size a PNG (IHDR, ISO/IEC 15948 §11.2.2) or JPEG (its SOF marker) header declares; false
// when the bytes are neither or no size is found (the decoder then decides).
bool DeclaredSize(const std::string& bytes, int64_t* width, int64_t* height) {
  const auto* b = reinterpret_cast<const uint8_t*>(bytes.data());
  if (bytes.size() >= 24 && IsPng(bytes)) {
    auto be32 = [&](size_t at) {
      return (int64_t{b[at]} << 24) | (int64_t{b[at + 1]} << 16) | (int64_t{b[at + 2]} << 8) |
             int64_t{b[at + 3]};
    };
    *width = be32(16);
    *height = be32(20);
    return true;
  }
  if (bytes.size() >= 2 && b[0] == 0xFF && b[1] == 0xD8) {
    // The markers up to the first SOFn (ITU T.81 §B.2.2: length, precision, Y, X), resyncing
    // on stray bytes as libjpeg does (it warns and goes on to the next 0xFF). Walked by hand:
    // this only bounds the size before libjpeg allocates.
    size_t at = 2;
    while (at + 1 < bytes.size()) {
      if (b[at] != 0xFF || b[at + 1] == 0x00 || b[at + 1] == 0xFF) {
        ++at;
        continue;
      }
      const uint8_t marker = b[at + 1];
      if (marker == 0x01 || (marker >= 0xD0 && marker <= 0xD9)) {  // no length
        at += 2;
        continue;
      }
      if (marker == 0xDA || at + 4 > bytes.size()) break;  // scan data: no SOF before it
      const bool sof =
          marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 && marker != 0xC8 && marker != 0xCC;
      if (sof && at + 9 <= bytes.size()) {
        *height = (int64_t{b[at + 5]} << 8) | b[at + 6];
        *width = (int64_t{b[at + 7]} << 8) | b[at + 8];
        return true;
      }
      at += 2 + ((size_t{b[at + 2]} << 8) | b[at + 3]);
    }
  }
  return false;
}

// 8-bit grey pixels (rows `width` bytes apart) of a PNG (libpng's simplified API) or a JPEG
// (libjpeg-turbo through JpegDecoder), told apart by their signatures; anything else is refused
// by name. No other codec ever sees the bytes: OpenCV's imdecode tried every codec it was built
// with, and GDCM's DICOM reader asserted on a 133-byte file named .png (fuzz_recorded_image).
bool DecodeGrey(const std::string& bytes, std::vector<uint8_t>* pixels, int* width, int* height,
                std::string* error) {
  if (IsPng(bytes)) {
    png_image image{};
    image.version = PNG_IMAGE_VERSION;
    if (!png_image_begin_read_from_memory(&image, bytes.data(), bytes.size()))
      return Invalid(error, std::string("cannot decode the PNG: ") + image.message);
    image.format = PNG_FORMAT_GRAY;
    pixels->resize(PNG_IMAGE_SIZE(image));
    // Without a background, libpng composites any alpha onto black.
    if (!png_image_finish_read(&image, nullptr, pixels->data(), 0, nullptr)) {
      const std::string why = image.message;
      png_image_free(&image);
      return Invalid(error, "cannot decode the PNG: " + why);
    }
    *width = static_cast<int>(image.width);
    *height = static_cast<int>(image.height);
    return true;
  }
  if (IsJpeg(bytes)) {
    JpegDecoder jpeg;
    const auto* data = reinterpret_cast<const uint8_t*>(bytes.data());
    if (!jpeg.ReadHeader(data, bytes.size(), width, height))
      return Invalid(error, std::string("cannot decode the JPEG: ") + jpeg.message());
    pixels->resize(static_cast<size_t>(*width) * static_cast<size_t>(*height));
    if (!jpeg.Decode(pixels->data(), static_cast<size_t>(*width)))
      return Invalid(error, std::string("cannot decode the JPEG: ") + jpeg.message());
    return true;
  }
  return Invalid(error, "not a PNG or a JPEG image (by its first bytes): only those are read");
}

}  // namespace

bool LoadRecordedImage(const RecordedEntry& entry, const std::string& camera_id, bool keep_jpeg,
                       camera_frame_t* msg, std::string* error) {
  std::string bytes;
  if (!ReadWholeFile(entry.path, &bytes, error)) return false;
  int64_t width = 0, height = 0;
  // Each side first: a PNG header holds sides up to 2^32 - 1, whose product overflows.
  if (DeclaredSize(bytes, &width, &height) &&
      (width > kMaxImagePixels || height > kMaxImagePixels || width * height > kMaxImagePixels))
    return Invalid(error, entry.path + ": the image declares " + std::to_string(width) + "x" +
                              std::to_string(height) + " px, more than a camera frame's " +
                              std::to_string(kMaxImagePixels / 1'000'000) + " MP");
  int image_width = 0, image_height = 0;
  std::vector<uint8_t> grey;
  if (!DecodeGrey(bytes, &grey, &image_width, &image_height, error)) {
    if (error) *error = entry.path + ": " + *error;
    return false;
  }
  msg->utime = entry.utime;
  msg->camera_id = camera_id;
  msg->width = image_width;
  msg->height = image_height;
  const std::string ext = Lower(fs::path(entry.path).extension().string());
  if (keep_jpeg && (ext == ".jpg" || ext == ".jpeg")) {
    msg->encoding = camera_frame_t::ENCODING_JPEG;
    msg->stride = 0;
    msg->data.assign(bytes.begin(), bytes.end());
  } else {
    msg->encoding = camera_frame_t::ENCODING_MONO8;
    msg->stride = image_width;
    msg->data = std::move(grey);
  }
  msg->size = static_cast<int32_t>(msg->data.size());
  return true;
}

bool LoadRecordedCloud(const RecordedEntry& entry, const std::string& lidar_id, lidar_frame_t* msg,
                       PcdInfo* info, std::string* error) {
  PcdInfo local;
  if (!ReadPcdFile(entry.path, PcdReadOptions{}, msg, info ? info : &local, error)) return false;
  msg->utime = entry.utime;
  msg->lidar_id = lidar_id;
  return true;
}

}  // namespace calibd
