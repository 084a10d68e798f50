#pragma once
/// \file
/// The cyclic status frame (1 Hz, classic CAN, 8 bytes) that tells the vehicle network and a
/// fleet logger how calibration stands, protected in the style of AUTOSAR E2E profile 1: a CRC-8
/// (SAE J1850) over a data id and the payload, and a 4-bit alive counter. deploy/calibd.dbc
/// describes the same layout for CAN tools. All multi-byte signals are little endian (Intel).
///
///   byte 0      CRC-8 SAE J1850 (poly 0x1D, init 0xFF, final XOR 0xFF) over the data id (low
///               byte, then high byte) followed by bytes 1..7
///   byte 1      bits 0-3 alive counter 0..14 (profile 1: 15 is never sent), bits 4-7 state
///   byte 2      progress, % 0..100 (0xFF: no session)
///   byte 3      bits 0-2 last verdict, bits 3-4 calibration state, bits 5-7 0
///   bytes 4-5   rotation delta of the last result vs the prior, 0.001 deg/bit (0xFFFF: none;
///               saturates at 65.534 deg)
///   bytes 6-7   calibration age, hours (0xFFFF: no calibration; saturates at 65534 h)

#include <array>
#include <cstddef>
#include <cstdint>

namespace calibd {

/// CRC-8 SAE J1850 as AUTOSAR's Crc_CalculateCRC8 computes it (check value 0x4B for
/// "123456789"). `crc` continues an earlier call: pass the previous result XOR 0xFF (the default
/// starts afresh).
uint8_t Crc8J1850(const uint8_t* data, size_t size, uint8_t start = 0xFF);

struct StatusFrame {
  enum class State : uint8_t {
    kIdle = 0,
    kCollecting = 1,
    kSolving = 2,
    kDone = 3,
    kFailed = 4,
    kAborted = 5
  };
  enum class Verdict : uint8_t { kNone = 0, kVerified = 1, kUpdated = 2, kRejected = 3 };
  enum class Calibration : uint8_t {
    kUnknown = 0,
    kValid = 1,
    kNotPerformed = 2,
    kRecalibrationRequired = 3
  };

  State state = State::kIdle;
  int progress_percent = -1;  ///< 0..100, -1: no session
  Verdict last_verdict = Verdict::kNone;
  Calibration calibration = Calibration::kUnknown;
  double rotation_delta_deg = -1.0;  ///< < 0: none
  double calibration_age_h = -1.0;   ///< < 0: no calibration
};

inline constexpr int kStatusFrameBytes = 8;
inline constexpr uint16_t kStatusFrameDefaultDataId = 0x0C1D;
using StatusFrameBytes = std::array<uint8_t, kStatusFrameBytes>;

/// Encodes `status` with alive counter `counter` (taken modulo 15).
StatusFrameBytes EncodeStatusFrame(const StatusFrame& status, int counter,
                                   uint16_t data_id = kStatusFrameDefaultDataId);

/// What a receiver checks (E2E profile 1): the CRC over data id and payload, and the counter.
struct StatusFrameCheck {
  bool crc_ok = false;
  int counter = 0;
  StatusFrame status;  ///< decoded (quantised) values
};
StatusFrameCheck DecodeStatusFrame(const StatusFrameBytes& bytes,
                                   uint16_t data_id = kStatusFrameDefaultDataId);

/// Sends one frame a period: the alive counter advances 0..14 and wraps.
class StatusFrameCounter {
 public:
  int Next() {
    const int c = counter_;
    counter_ = (counter_ + 1) % 15;
    return c;
  }

 private:
  int counter_ = 0;
};

}  // namespace calibd
