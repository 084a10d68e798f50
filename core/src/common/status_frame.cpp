#include "calibd/core/common/status_frame.hpp"

#include <algorithm>
#include <cmath>

namespace calibd {

uint8_t Crc8J1850(const uint8_t* data, size_t size, uint8_t start) {
  // Bitwise MSB-first with polynomial x^8 + x^4 + x^3 + x^2 + 1 (0x1D); 8 bytes a second need no
  // table.
  uint8_t crc = start;
  for (size_t i = 0; i < size; ++i) {
    crc ^= data[i];
    for (int b = 0; b < 8; ++b)
      crc = (crc & 0x80u) != 0 ? static_cast<uint8_t>((crc << 1) ^ 0x1Du)
                               : static_cast<uint8_t>(crc << 1);
  }
  return static_cast<uint8_t>(crc ^ 0xFFu);
}

namespace {

uint16_t Quantise(double value, double scale, bool present) {
  if (!present || !std::isfinite(value)) return 0xFFFF;
  return static_cast<uint16_t>(std::clamp(std::lround(value / scale), 0L, 0xFFFEL));
}

uint8_t FrameCrc(const StatusFrameBytes& b, uint16_t data_id) {
  uint8_t buffer[2 + kStatusFrameBytes - 1];
  buffer[0] = static_cast<uint8_t>(data_id & 0xFFu);
  buffer[1] = static_cast<uint8_t>(data_id >> 8);
  std::copy(b.begin() + 1, b.end(), buffer + 2);
  return Crc8J1850(buffer, sizeof(buffer));
}

}  // namespace

StatusFrameBytes EncodeStatusFrame(const StatusFrame& s, int counter, uint16_t data_id) {
  StatusFrameBytes b{};
  const int c = ((counter % 15) + 15) % 15;
  b[1] = static_cast<uint8_t>(c | (static_cast<unsigned>(s.state) << 4));
  b[2] = s.progress_percent < 0 ? 0xFF : static_cast<uint8_t>(std::min(100, s.progress_percent));
  b[3] = static_cast<uint8_t>((static_cast<unsigned>(s.last_verdict) & 0x7u) |
                              ((static_cast<unsigned>(s.calibration) & 0x3u) << 3));
  const uint16_t rot = Quantise(s.rotation_delta_deg, 0.001, s.rotation_delta_deg >= 0.0);
  const uint16_t age = Quantise(s.calibration_age_h, 1.0, s.calibration_age_h >= 0.0);
  b[4] = static_cast<uint8_t>(rot & 0xFFu);
  b[5] = static_cast<uint8_t>(rot >> 8);
  b[6] = static_cast<uint8_t>(age & 0xFFu);
  b[7] = static_cast<uint8_t>(age >> 8);
  b[0] = FrameCrc(b, data_id);
  return b;
}

StatusFrameCheck DecodeStatusFrame(const StatusFrameBytes& b, uint16_t data_id) {
  StatusFrameCheck r;
  r.crc_ok = FrameCrc(b, data_id) == b[0];
  r.counter = b[1] & 0x0F;
  r.status.state = static_cast<StatusFrame::State>(b[1] >> 4);
  r.status.progress_percent = b[2] == 0xFF ? -1 : b[2];
  r.status.last_verdict = static_cast<StatusFrame::Verdict>(b[3] & 0x7u);
  r.status.calibration = static_cast<StatusFrame::Calibration>((b[3] >> 3) & 0x3u);
  const unsigned rot = b[4] | (b[5] << 8), age = b[6] | (b[7] << 8);
  r.status.rotation_delta_deg = rot == 0xFFFF ? -1.0 : rot * 0.001;
  r.status.calibration_age_h = age == 0xFFFF ? -1.0 : static_cast<double>(age);
  return r;
}

}  // namespace calibd
