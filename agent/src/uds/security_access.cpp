#include "calibd/agent/uds/security_access.hpp"

#include <fcntl.h>
#include <openssl/crypto.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>
#include <sys/random.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdio>
#include <cstring>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd::uds {
namespace {

constexpr char kLockoutHeader[] = "calibd-security 1";

bool FillRandom(uint8_t* out, size_t size) {
  size_t done = 0;
  while (done < size) {
    const ssize_t n = getrandom(out + done, size - done, 0);
    if (n < 0) {
      if (errno == EINTR) continue;
      return false;
    }
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace

bool LoadSecret(const std::string& path, std::string* secret, std::string* error) {
  const int fd = ::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW);
  if (fd < 0) {
    *error = path + ": cannot open the secret file: " + std::strerror(errno);
    return false;
  }
  struct stat st {};
  bool ok = ::fstat(fd, &st) == 0;
  char mode[8];
  if (!ok) {
    *error = path + ": " + std::strerror(errno);
  } else if (!S_ISREG(st.st_mode)) {
    *error = path + ": the secret must be a regular file";
    ok = false;
  } else if ((st.st_mode & 077) != 0) {
    std::snprintf(mode, sizeof(mode), "%04o", static_cast<unsigned>(st.st_mode & 07777));
    *error = path + ": mode " + mode +
             " lets group or others access the secret; chmod 600 it (owner only)";
    ok = false;
  } else if (st.st_uid != 0 && st.st_uid != ::geteuid()) {
    *error = path + ": owned by uid " + std::to_string(st.st_uid) +
             ", must be owned by root or by the agent's user";
    ok = false;
  } else if (st.st_size < static_cast<off_t>(kMinSecretSize) ||
             st.st_size > static_cast<off_t>(kMaxSecretSize)) {
    *error = path + ": the secret must hold " + std::to_string(kMinSecretSize) + " to " +
             std::to_string(kMaxSecretSize) + " bytes (has " + std::to_string(st.st_size) + ")";
    ok = false;
  }
  if (ok) {
    secret->assign(static_cast<size_t>(st.st_size), '\0');
    size_t done = 0;
    while (ok && done < secret->size()) {
      const ssize_t n = ::read(fd, secret->data() + done, secret->size() - done);
      if (n < 0 && errno == EINTR) continue;
      if (n <= 0) {
        *error = path + ": short read of the secret";
        ok = false;
      } else {
        done += static_cast<size_t>(n);
      }
    }
  }
  ::close(fd);
  return ok;
}

bool ComputeKey(const std::string& secret, const uint8_t* seed, size_t seed_size,
                uint8_t key[kKeySize]) {
  uint8_t mac[EVP_MAX_MD_SIZE];
  unsigned int mac_size = 0;
  if (HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()), seed, seed_size, mac,
           &mac_size) == nullptr ||
      mac_size < kKeySize) {
    return false;
  }
  std::memcpy(key, mac, kKeySize);
  OPENSSL_cleanse(mac, sizeof(mac));
  return true;
}

bool SecurityAccess::Init(const UdsConfig& config, int64_t now_us, int64_t now_unix_us,
                          std::string* error) {
  config_ = config;
  path_ = config.state_dir + "/security_lockout";
  unix_minus_mono_us_ = now_unix_us - now_us;
  unlocked_ = false;
  seed_pending_ = false;
  failed_attempts_ = 0;
  delay_until_us_ = 0;
  warning_.clear();
  if (!LoadSecret(config.secret_file, &secret_, error)) return false;

  std::string contents, read_error;
  if (!ReadWholeFile(path_, &contents, &read_error)) return true;  // missing: no lockout
  int attempts = 0;
  int64_t until_unix_us = 0;
  char header[32] = {0}, extra = 0;
  if (std::sscanf(contents.c_str(),
                  "%31[^\n]\nfailed_attempts %d\nlockout_until_unix_us %" SCNd64 "\n%c", header,
                  &attempts, &until_unix_us, &extra) != 3 ||
      std::strcmp(header, kLockoutHeader) != 0 || attempts < 0 || until_unix_us < 0) {
    warning_ = path_ + ": corrupt, starting without a lockout";
    return true;
  }
  failed_attempts_ = attempts < config.max_key_attempts ? attempts : config.max_key_attempts;
  if (until_unix_us > now_unix_us) {
    // Bounded by one delay from now: a clock set back must not lock the tester out for longer.
    int64_t remaining = until_unix_us - now_unix_us;
    if (remaining > config.lockout_delay_us) remaining = config.lockout_delay_us;
    delay_until_us_ = now_us + remaining;
  } else if (failed_attempts_ >= config.max_key_attempts) {
    failed_attempts_ = 0;  // the delay passed while the agent was down
  }
  return true;
}

Nrc SecurityAccess::RequestSeed(int64_t now_us, uint8_t seed[kSeedSize]) {
  if (delay_active(now_us)) return kNrcRequiredTimeDelayNotExpired;
  if (delay_until_us_ != 0) {
    // The delay just ended: fresh attempts (ISO 14229-1 §9.4.1).
    delay_until_us_ = 0;
    failed_attempts_ = 0;
    Persist();
  }
  if (unlocked_) {
    std::memset(seed, 0, kSeedSize);  // §9.4.2.2: already unlocked
    return kNrcNone;
  }
  if (!FillRandom(seed_.data(), seed_.size())) return kNrcConditionsNotCorrect;
  std::memcpy(seed, seed_.data(), kSeedSize);
  seed_pending_ = true;
  return kNrcNone;
}

Nrc SecurityAccess::SendKey(const uint8_t* key, size_t size, int64_t now_us) {
  if (!seed_pending_) return kNrcRequestSequenceError;
  if (size != kKeySize) return kNrcIncorrectMessageLength;
  if (delay_active(now_us)) return kNrcRequiredTimeDelayNotExpired;
  seed_pending_ = false;  // a seed is good for one key
  uint8_t expected[kKeySize];
  const bool computed = ComputeKey(secret_, seed_.data(), seed_.size(), expected);
  const bool match = computed && CRYPTO_memcmp(expected, key, kKeySize) == 0;
  OPENSSL_cleanse(expected, sizeof(expected));
  if (match) {
    unlocked_ = true;
    if (failed_attempts_ != 0) {
      failed_attempts_ = 0;
      Persist();
    }
    return kNrcNone;
  }
  ++failed_attempts_;
  if (failed_attempts_ >= config_.max_key_attempts) {
    delay_until_us_ = now_us + config_.lockout_delay_us;
    Persist();
    return kNrcExceededNumberOfAttempts;
  }
  Persist();
  return kNrcInvalidKey;
}

void SecurityAccess::Lock() {
  unlocked_ = false;
  seed_pending_ = false;
}

void SecurityAccess::Persist() {
  const int64_t until_unix_us = delay_until_us_ > 0 ? delay_until_us_ + unix_minus_mono_us_ : 0;
  char text[128];
  std::snprintf(text, sizeof(text), "%s\nfailed_attempts %d\nlockout_until_unix_us %" PRId64 "\n",
                kLockoutHeader, failed_attempts_, until_unix_us);
  std::string error;
  if (!WriteFileAtomic(path_, text, &error)) warning_ = "lockout not persisted: " + error;
}

}  // namespace calibd::uds
