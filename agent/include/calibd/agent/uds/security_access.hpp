#pragma once
/// \file
/// SecurityAccess 0x27 levels 0x01 requestSeed / 0x02 sendKey (ISO 14229-1 §9.4): random
/// 16-byte seeds, key = the first 16 bytes of HMAC-SHA256(secret, seed), a failed-attempt counter
/// and a required time delay that survive restarts.
///
/// Sequence (§9.4.1): sendKey needs the seed of the immediately preceding requestSeed (else
/// 0x24); a wrong key consumes the seed and counts an attempt: 0x35 invalidKey until the
/// max_key_attempts-th, which answers 0x36 exceededNumberOfAttempts and starts the delay, during
/// which requestSeed answers 0x37 requiredTimeDelayNotExpired. When the delay ends the counter
/// starts again from 0. While unlocked, requestSeed returns an all-zero seed (§9.4.2.2).
///
/// The counter and the delay's end (wall-clock, unix us) are written atomically to
/// `<state_dir>/security_lockout` on every change, and read at Init: restarting the agent (or
/// 0x11 ECUReset) neither clears a running delay nor gives fresh attempts. A delay read back is
/// never longer than lockout_delay_us from Init (a wall clock set back cannot extend it). A
/// missing file means no lockout; a corrupt one too, reported in warning().

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/agent/uds/uds_config.hpp"
#include "calibd/agent/uds/uds_types.hpp"

namespace calibd::uds {

inline constexpr size_t kSeedSize = 16;
inline constexpr size_t kKeySize = 16;
inline constexpr size_t kMinSecretSize = 16;
inline constexpr size_t kMaxSecretSize = 256;

/// Reads the secret file with the checks of UdsConfig::secret_file. False with `error` saying
/// what is wrong (e.g. "/etc/calibd/secret: mode 0644 lets group/others read it; chmod 600").
bool LoadSecret(const std::string& path, std::string* secret, std::string* error);

/// key = first kKeySize bytes of HMAC-SHA256(secret, seed) (OpenSSL). False if OpenSSL fails.
bool ComputeKey(const std::string& secret, const uint8_t* seed, size_t seed_size,
                uint8_t key[kKeySize]);

class SecurityAccess {
 public:
  /// Loads the secret (false with `error` when it fails its checks) and the persisted lockout.
  /// `now_us` is the caller's monotonic clock, `now_unix_us` the wall clock at the same moment.
  bool Init(const UdsConfig& config, int64_t now_us, int64_t now_unix_us, std::string* error);

  /// requestSeed: writes the seed to `seed` and returns kNrcNone, or the NRC.
  Nrc RequestSeed(int64_t now_us, uint8_t seed[kSeedSize]);
  /// sendKey (the key bytes after the sub-function): kNrcNone when it unlocks, or the NRC.
  Nrc SendKey(const uint8_t* key, size_t size, int64_t now_us);
  /// Back to locked (session change, S3 timeout); any outstanding seed is dropped.
  void Lock();

  bool unlocked() const { return unlocked_; }
  int failed_attempts() const { return failed_attempts_; }
  bool delay_active(int64_t now_us) const { return delay_until_us_ > now_us; }
  /// What Init found wrong with the lockout file, or the last failure to write it; else empty.
  const std::string& warning() const { return warning_; }

 private:
  void Persist();

  UdsConfig config_;
  std::string secret_;
  std::string path_;
  int64_t unix_minus_mono_us_ = 0;  ///< wall clock - monotonic clock, from Init
  bool unlocked_ = false;
  bool seed_pending_ = false;
  std::array<uint8_t, kSeedSize> seed_{};
  int failed_attempts_ = 0;
  int64_t delay_until_us_ = 0;  ///< monotonic; <= now: no delay
  std::string warning_;
};

}  // namespace calibd::uds
