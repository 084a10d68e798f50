// UdsServer SecurityAccess 0x27 (ISO 14229-1 §9.4): seed/key with HMAC-SHA256, the attempt
// counter and the required time delay persisted across restarts, and the secret file's checks.

#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <openssl/hmac.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <memory>
#include <set>
#include <vector>

#include "calibd/agent/uds/security_access.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "temp_dir.hpp"
#include "uds_fake_backend.hpp"

namespace calibd::uds {
namespace {

using namespace calibd::testing::uds_test;  // NOLINT(google-build-using-namespace)

// The expected key, computed here with OpenSSL directly (not through ComputeKey).
Bytes ExpectedKey(const uint8_t* seed) {
  uint8_t mac[EVP_MAX_MD_SIZE];
  unsigned int size = 0;
  const std::string secret = calibd::testing::kTestSecret;
  HMAC(EVP_sha256(), secret.data(), static_cast<int>(secret.size()), seed, kSeedSize, mac, &size);
  return Bytes(mac, mac + kKeySize);
}

Bytes SendKeyRequest(const Bytes& key) {
  Bytes r(2 + key.size());
  r[0] = 0x27;
  r[1] = 0x02;
  std::copy(key.begin(), key.end(), r.begin() + 2);
  return r;
}

class UdsSecurityTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = calibd::testing::TestUdsConfig(dir_.path().string());
    Restart(kT0, kUnix0);
  }
  /// A new server over the same state directory, as after an agent restart.
  void Restart(int64_t now_us, int64_t now_unix_us) {
    server_ = std::make_unique<UdsServer>(config_, &backend_);
    std::string error;
    ASSERT_TRUE(server_->Init(now_us, now_unix_us, &error)) << error;
  }
  Bytes Tx(const Bytes& request, int64_t t) { return Send(*server_, request, t); }

  TempDir dir_;
  UdsConfig config_;
  FakeUdsBackend backend_;
  std::unique_ptr<UdsServer> server_;
};

TEST(SecurityKeyTest, KnownVector) {
  // openssl dgst -sha256 -mac HMAC -macopt key:calibd-test-secret-0123456789abc over the bytes
  // 00 01 .. 0F, first 16 bytes.
  uint8_t seed[kSeedSize];
  for (size_t i = 0; i < kSeedSize; ++i) seed[i] = static_cast<uint8_t>(i);
  uint8_t key[kKeySize];
  ASSERT_TRUE(ComputeKey(calibd::testing::kTestSecret, seed, kSeedSize, key));
  const Bytes expected = {0xab, 0x2b, 0x20, 0x85, 0xd1, 0xde, 0xf4, 0x6f,
                          0xcb, 0x78, 0x11, 0x1f, 0x6a, 0xdc, 0xca, 0xd6};
  EXPECT_EQ(Bytes(key, key + kKeySize), expected);
}

TEST_F(UdsSecurityTest, SeedThenRightKeyUnlocks) {
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  const Bytes seed = Tx({0x27, 0x01}, kT0);
  ASSERT_EQ(seed.size(), 2 + kSeedSize);
  EXPECT_EQ(seed[0], 0x67);
  EXPECT_EQ(seed[1], 0x01);
  EXPECT_NE(Bytes(seed.begin() + 2, seed.end()), Bytes(kSeedSize, 0));
  const Bytes seed2 = Tx({0x27, 0x01}, kT0);
  EXPECT_NE(seed, seed2) << "a fresh random seed per request";
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&seed2[2])), kT0), (Bytes{0x67, 0x02}));
  EXPECT_TRUE(server_->security_unlocked());
  // §9.4.2.2: already unlocked -> an all-zero seed.
  Bytes zero(2 + kSeedSize, 0);
  zero[0] = 0x67;
  zero[1] = 0x01;
  EXPECT_EQ(Tx({0x27, 0x01}, kT0), zero);
  EXPECT_EQ(Tx({0x27, 0x02, 0x00}, kT0), (Bytes{0x7F, 0x27, 0x24})) << "no seed outstanding";
}

// Seeds come from the kernel's CSPRNG (getrandom): 20,000 requests over 10 agent restarts give no
// repeated seed, the bits are balanced, and a key for an earlier seed is refused (only the last
// seed is good, for one key).
TEST_F(UdsSecurityTest, SeedsNeverRepeatAcrossRestartsAndOldSeedsAreDead) {
  std::set<Bytes> seen;
  uint64_t ones = 0, bits = 0;
  for (int restart = 0; restart < 10; ++restart) {
    Restart(kT0, kUnix0);
    ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
    for (int i = 0; i < 2000; ++i) {
      const Bytes r = Tx({0x27, 0x01}, kT0);
      ASSERT_EQ(r.size(), 2 + kSeedSize);
      const Bytes seed(r.begin() + 2, r.end());
      EXPECT_TRUE(seen.insert(seed).second) << "seed repeated after " << seen.size();
      for (uint8_t b : seed) ones += static_cast<uint64_t>(__builtin_popcount(b));
      bits += 8 * kSeedSize;
    }
  }
  EXPECT_EQ(seen.size(), 20000u);
  // 2.56 M fair bits: the fraction of ones is within 0.5 +- 0.003 (about 10 sigma).
  EXPECT_NEAR(static_cast<double>(ones) / static_cast<double>(bits), 0.5, 0.003);

  const Bytes first = Tx({0x27, 0x01}, kT0);
  const Bytes second = Tx({0x27, 0x01}, kT0);
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&first[2])), kT0), (Bytes{0x7F, 0x27, 0x35}))
      << "the key of a superseded seed";
  EXPECT_FALSE(server_->security_unlocked());
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&second[2])), kT0), (Bytes{0x7F, 0x27, 0x24}))
      << "a wrong key consumed the seed";
  const Bytes third = Tx({0x27, 0x01}, kT0);
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&third[2])), kT0), (Bytes{0x67, 0x02}));
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&third[2])), kT0), (Bytes{0x7F, 0x27, 0x24}))
      << "a seed is good for one key";
}

TEST_F(UdsSecurityTest, Nrcs) {
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  EXPECT_EQ(Tx({0x27}, kT0), (Bytes{0x7F, 0x27, 0x13}));
  EXPECT_EQ(Tx({0x27, 0x03}, kT0), (Bytes{0x7F, 0x27, 0x12}));
  EXPECT_EQ(Tx({0x27, 0x01, 0x00}, kT0), (Bytes{0x7F, 0x27, 0x13}));
  // sendKey without a seed: 0x24 before the length check.
  EXPECT_EQ(Tx({0x27, 0x02, 0x01}, kT0), (Bytes{0x7F, 0x27, 0x24}));
  ASSERT_EQ(Tx({0x27, 0x01}, kT0).size(), 18u);
  EXPECT_EQ(Tx({0x27, 0x02, 0x01}, kT0), (Bytes{0x7F, 0x27, 0x13}));
  EXPECT_EQ(server_->security_unlocked(), false);
}

TEST_F(UdsSecurityTest, ThreeWrongKeysLockOutAcrossARestart) {
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  const Bytes wrong(kKeySize, 0x55);
  for (int attempt = 1; attempt <= 3; ++attempt) {
    ASSERT_EQ(Tx({0x27, 0x01}, kT0).size(), 18u);
    EXPECT_EQ(Tx(SendKeyRequest(wrong), kT0),
              (Bytes{0x7F, 0x27, static_cast<uint8_t>(attempt < 3 ? 0x35 : 0x36)}))
        << attempt;
  }
  EXPECT_EQ(Tx({0x27, 0x01}, kT0 + kS), (Bytes{0x7F, 0x27, 0x37}));

  // Restart 2 s later; the new process's monotonic clock starts anywhere (here at 7 s), so the
  // delay ends at 15 s on it. TesterPresent keeps the extended session (S3) meanwhile.
  Restart(7 * kS, kUnix0 + 2 * kS);
  ASSERT_EQ(Tx({0x10, 0x03}, 7 * kS)[0], 0x50);
  EXPECT_EQ(Tx({0x27, 0x01}, 7 * kS), (Bytes{0x7F, 0x27, 0x37}));
  EXPECT_EQ(Tx({0x3E, 0x00}, 11 * kS), (Bytes{0x7E, 0x00}));
  EXPECT_EQ(Tx({0x27, 0x01}, 15 * kS - 1), (Bytes{0x7F, 0x27, 0x37}));
  // 10 s after the third wrong key: seeds again, with fresh attempts.
  const Bytes seed = Tx({0x27, 0x01}, 15 * kS);
  ASSERT_EQ(seed.size(), 18u);
  EXPECT_EQ(Tx(SendKeyRequest(wrong), 15 * kS), (Bytes{0x7F, 0x27, 0x35}));
  const Bytes seed2 = Tx({0x27, 0x01}, 15 * kS);
  EXPECT_EQ(Tx(SendKeyRequest(ExpectedKey(&seed2[2])), 15 * kS), (Bytes{0x67, 0x02}));
}

TEST_F(UdsSecurityTest, FailedAttemptsSurviveARestart) {
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  const Bytes wrong(kKeySize, 0x55);
  for (int attempt = 1; attempt <= 2; ++attempt) {
    ASSERT_EQ(Tx({0x27, 0x01}, kT0).size(), 18u);
    ASSERT_EQ(Tx(SendKeyRequest(wrong), kT0), (Bytes{0x7F, 0x27, 0x35}));
  }
  Restart(kT0 + kS, kUnix0 + kS);  // e.g. 0x11 ECUReset to get fresh attempts: not so
  ASSERT_EQ(Tx({0x10, 0x03}, kT0 + kS)[0], 0x50);
  ASSERT_EQ(Tx({0x27, 0x01}, kT0 + kS).size(), 18u);
  EXPECT_EQ(Tx(SendKeyRequest(wrong), kT0 + kS), (Bytes{0x7F, 0x27, 0x36}));
}

TEST_F(UdsSecurityTest, LockoutReadBackIsBoundedByOneDelay) {
  // A lockout file written with a wall clock far ahead (or read after the clock was set back).
  std::ofstream(config_.state_dir + "/security_lockout")
      << "calibd-security 1\nfailed_attempts 3\nlockout_until_unix_us " << kUnix0 + 3600 * kS
      << "\n";
  Restart(kT0, kUnix0);
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  EXPECT_EQ(Tx({0x3E, 0x00}, kT0 + 4 * kS), (Bytes{0x7E, 0x00}));
  EXPECT_EQ(Tx({0x27, 0x01}, kT0 + 8 * kS), (Bytes{0x7F, 0x27, 0x37}));
  EXPECT_EQ(Tx({0x27, 0x01}, kT0 + 10 * kS).size(), 18u) << "not 3600 s";
}

TEST_F(UdsSecurityTest, CorruptLockoutFileIsReportedAndMeansNoLockout) {
  std::ofstream(config_.state_dir + "/security_lockout") << "calibd-security 1\nfailed_att";
  Restart(kT0, kUnix0);
  EXPECT_NE(server_->warnings().find("security_lockout: corrupt"), std::string::npos)
      << server_->warnings();
  ASSERT_EQ(Tx({0x10, 0x03}, kT0)[0], 0x50);
  EXPECT_EQ(Tx({0x27, 0x01}, kT0).size(), 18u);
}

TEST_F(UdsSecurityTest, SecretFileMustBeOwnerOnly) {
  std::string error;
  calibd::testing::WriteFileWithMode(config_.secret_file, calibd::testing::kTestSecret, 0644);
  UdsServer open_secret(config_, &backend_);
  EXPECT_FALSE(open_secret.Init(kT0, kUnix0, &error));
  EXPECT_EQ(error, config_.secret_file +
                       ": mode 0644 lets group or others access the secret; chmod 600 it (owner "
                       "only)");
  calibd::testing::WriteFileWithMode(config_.secret_file, "short", 0600);
  UdsServer short_secret(config_, &backend_);
  EXPECT_FALSE(short_secret.Init(kT0, kUnix0, &error));
  EXPECT_NE(error.find("16 to 256 bytes (has 5)"), std::string::npos) << error;
  UdsConfig missing = config_;
  missing.secret_file = config_.state_dir + "/no-such-secret";
  UdsServer no_secret(missing, &backend_);
  EXPECT_FALSE(no_secret.Init(kT0, kUnix0, &error));
  EXPECT_NE(error.find("cannot open the secret file"), std::string::npos) << error;
  UdsConfig directory = config_;
  directory.secret_file = config_.state_dir;
  UdsServer dir_secret(directory, &backend_);
  EXPECT_FALSE(dir_secret.Init(kT0, kUnix0, &error));
}

}  // namespace
}  // namespace calibd::uds
