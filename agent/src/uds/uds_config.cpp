#include "calibd/agent/uds/uds_config.hpp"

#include <string>

#include "calibd/agent/uds/did_codec.hpp"

namespace calibd::uds {
namespace {

bool Fail(std::string* error, const std::string& what) {
  if (error) *error = "uds." + what;
  return false;
}

}  // namespace

bool UdsConfig::IsValid(std::string* error) const {
  if (secret_file.empty()) return Fail(error, "secret_file: must name the secret file");
  if (state_dir.empty()) return Fail(error, "state_dir: must name a directory");
  if (max_key_attempts < 1 || max_key_attempts > 255) {
    return Fail(error, "max_key_attempts: must be in [1, 255] (got " +
                           std::to_string(max_key_attempts) + ")");
  }
  if (lockout_delay_us < 0) {
    return Fail(error,
                "lockout_delay_us: must be >= 0 (got " + std::to_string(lockout_delay_us) + ")");
  }
  if (s3_us <= 0) return Fail(error, "s3_us: must be > 0 (got " + std::to_string(s3_us) + ")");
  // ISO 14229-1 §9.2.3 Table 30: P2server_max in 1 ms, P2*server_max in 10 ms, 2 bytes each.
  if (p2_ms < 0 || p2_ms > 0xFFFF) {
    return Fail(error, "p2_ms: must be in [0, 65535] (got " + std::to_string(p2_ms) + ")");
  }
  if (p2_star_ms < 0 || p2_star_ms > 0xFFFF * 10 || p2_star_ms % 10 != 0) {
    return Fail(error, "p2_star_ms: must be a multiple of 10 in [0, 655350] (got " +
                           std::to_string(p2_star_ms) + ")");
  }
  if (ecu_serial.size() > kEcuSerialSize) {
    return Fail(error, "ecu_serial: at most " + std::to_string(kEcuSerialSize) +
                           " characters (got " + std::to_string(ecu_serial.size()) + ")");
  }
  for (char c : ecu_serial) {
    if (c < 0x20 || c > 0x7E) return Fail(error, "ecu_serial: printable ASCII only");
  }
  return true;
}

}  // namespace calibd::uds
