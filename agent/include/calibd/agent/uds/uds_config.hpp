#pragma once
/// \file
/// Settings of the UDS server: a value struct with its defaults.
/// Loading from the agent's YAML comes with the agent wiring.

#include <cstdint>
#include <string>

namespace calibd::uds {

struct UdsConfig {
  /// File holding the per-vehicle SecurityAccess secret: its bytes, as they are (no trimming),
  /// are the HMAC-SHA256 key; at least 16 bytes. Must be a regular file owned by root or by the
  /// server's user and neither readable nor writable by group or others (mode 0600 or 0400).
  std::string secret_file;
  /// Directory for the server's persistent state: `security_lockout` (failed key attempts and
  /// the lockout expiry) and `dtc_status` (the DTC store). Must exist.
  std::string state_dir;
  /// Failed sendKey attempts before 0x36 exceededNumberOfAttempts starts the delay (>= 1).
  int max_key_attempts = 3;
  /// requiredTimeDelay after the attempts ran out, us: requestSeed answers 0x37 until it ends,
  /// across restarts. Longer slows brute force; shorter lets a mistyped tester retry sooner.
  int64_t lockout_delay_us = 10LL * 1000 * 1000;
  /// S3server, us: a non-default session without any request for this long returns to the
  /// default session (ISO 14229-2 §9.3, 5000 ms nominal).
  int64_t s3_us = 5LL * 1000 * 1000;
  /// P2server_max and P2*server_max reported in the 0x10 positive response, ms. P2* is sent in
  /// 10 ms units, so it must be a multiple of 10 (ISO 14229-1 §9.2.3 Table 30).
  int p2_ms = 50;
  int p2_star_ms = 5000;
  /// ECU serial number for DID 0xF18C: printable ASCII, at most 16 characters.
  std::string ecu_serial;

  /// On failure `error` names the key, e.g. "uds.p2_star_ms: must be a multiple of 10 in
  /// [0, 655350] (got 5005)".
  bool IsValid(std::string* error) const;
};

}  // namespace calibd::uds
