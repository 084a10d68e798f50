#include "calibd/agent/uds/did_codec.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <ctime>
#include <limits>

namespace calibd::uds {
namespace {

template <typename Int>
Int Scale(double value, double lsb) {
  if (std::isnan(value)) return 0;
  const double scaled = std::round(value / lsb);
  if (scaled <= static_cast<double>(std::numeric_limits<Int>::min())) {
    return std::numeric_limits<Int>::min();
  }
  if (scaled >= static_cast<double>(std::numeric_limits<Int>::max())) {
    return std::numeric_limits<Int>::max();
  }
  return static_cast<Int>(scaled);
}

uint8_t Bcd(int v) { return static_cast<uint8_t>(((v / 10) % 10) << 4 | (v % 10)); }

}  // namespace

int32_t ScaleToInt32(double value, double lsb) { return Scale<int32_t>(value, lsb); }
uint16_t ScaleToUint16(double value, double lsb) { return Scale<uint16_t>(value, lsb); }

size_t PutU16(uint8_t* out, uint16_t v) {
  out[0] = static_cast<uint8_t>(v >> 8);
  out[1] = static_cast<uint8_t>(v);
  return 2;
}

size_t PutI32(uint8_t* out, int32_t v) {
  const auto u = static_cast<uint32_t>(v);
  out[0] = static_cast<uint8_t>(u >> 24);
  out[1] = static_cast<uint8_t>(u >> 16);
  out[2] = static_cast<uint8_t>(u >> 8);
  out[3] = static_cast<uint8_t>(u);
  return 4;
}

size_t PutPaddedAscii(uint8_t* out, std::string_view text, size_t size) {
  const size_t n = text.size() < size ? text.size() : size;
  std::memcpy(out, text.data(), n);
  std::memset(out + n, ' ', size - n);
  return size;
}

size_t EncodeExtrinsic(const ExtrinsicFigures& e, uint8_t* out) {
  const double values[6] = {e.x_m, e.y_m, e.z_m, e.roll_deg, e.pitch_deg, e.yaw_deg};
  const double lsbs[6] = {kTranslationLsbM, kTranslationLsbM, kTranslationLsbM,
                          kAngleLsbDeg,     kAngleLsbDeg,     kAngleLsbDeg};
  size_t n = 0;
  for (int i = 0; i < 6; ++i) {
    n += PutI32(out + n, e.available ? ScaleToInt32(values[i], lsbs[i]) : kExtrinsicNotAvailable);
  }
  return n;
}

size_t EncodeQuality(const QualityFigures& q, uint8_t* out) {
  size_t n = 0;
  n += PutU16(out + n, ScaleToUint16(q.reprojection_mean_px, kReprojectionLsbPx));
  n += PutU16(out + n, ScaleToUint16(q.residual_rms_m, kLengthFigureLsbM));
  n += PutU16(out + n, ScaleToUint16(q.rotation_sigma_deg, kRotationFigureLsbDeg));
  n += PutU16(out + n, ScaleToUint16(q.translation_sigma_m, kLengthFigureLsbM));
  n += PutU16(out + n, ScaleToUint16(q.frames_used, 1.0));
  n += PutU16(out + n, ScaleToUint16(q.boards_used, 1.0));
  auto bound = [](double value, double lsb) {
    return value > 0.0 ? ScaleToUint16(value, lsb) : kBoundNotAvailable;
  };
  n += PutU16(out + n, bound(q.rotation_bound_deg, kRotationFigureLsbDeg));
  n += PutU16(out + n, bound(q.translation_bound_m, kLengthFigureLsbM));
  return n;
}

size_t EncodeCoverage(const CaptureCoverage& c, uint8_t* out) {
  auto byte = [](int v) { return static_cast<uint8_t>(std::clamp(v, 0, 0xFF)); };
  size_t n = 0;
  out[n++] = c.moving ? 0 : 1;
  out[n++] = static_cast<uint8_t>(c.distance_bins & 0xFFu);
  out[n++] = byte(c.gates.min_distance_bins);
  n += PutU16(out + n, static_cast<uint16_t>(c.image_cells & 0xFFFFu));
  out[n++] = byte(c.gates.min_image_cells);
  for (const int v : {c.frames_with_boards, c.gates.min_frames, c.gates.target_frames, c.boards,
                      c.gates.min_boards})
    n += PutU16(out + n, ScaleToUint16(v, 1.0));
  return n;
}

CaptureCoverage DecodeCoverage(const uint8_t* in) {
  auto u16 = [in](int at) { return (in[at] << 8) | in[at + 1]; };
  CaptureCoverage c;
  c.moving = in[0] == 0;
  c.distance_bins = in[1];
  c.gates.min_distance_bins = in[2];
  c.image_cells = static_cast<uint32_t>(u16(3));
  c.gates.min_image_cells = in[5];
  c.frames_with_boards = u16(6);
  c.gates.min_frames = u16(8);
  c.gates.target_frames = u16(10);
  c.boards = u16(12);
  c.gates.min_boards = u16(14);
  return c;
}

size_t EncodeBcdDate(int64_t unix_s, uint8_t* out) {
  std::memset(out, 0, 4);
  if (unix_s <= 0) return 4;
  const std::time_t t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  if (gmtime_r(&t, &tm) == nullptr) return 4;
  const int year = tm.tm_year + 1900;
  out[0] = Bcd(year / 100);
  out[1] = Bcd(year % 100);
  out[2] = Bcd(tm.tm_mon + 1);
  out[3] = Bcd(tm.tm_mday);
  return 4;
}

}  // namespace calibd::uds
