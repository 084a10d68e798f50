// UdsServer: sessions, TesterPresent, S3, ECUReset, the NRC framework (ISO 14229-1 §7.5) and the
// data identifiers, byte for byte. Security: test_uds_security.cpp; routines:
// test_uds_routines.cpp; DTCs: test_uds_dtc.cpp.

#include "calibd/agent/uds/uds_server.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "calibd/agent/uds/security_access.hpp"
#include "temp_dir.hpp"
#include "uds_fake_backend.hpp"

namespace calibd::uds {
namespace {

using namespace calibd::testing::uds_test;  // NOLINT(google-build-using-namespace)

class UdsServerTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = calibd::testing::TestUdsConfig(dir_.path().string());
    server_ = std::make_unique<UdsServer>(config_, &backend_);
    std::string error;
    ASSERT_TRUE(server_->Init(kT0, kUnix0, &error)) << error;
  }
  Bytes Tx(const Bytes& request, int64_t t = kT0, bool functional = false) {
    return Send(*server_, request, t, functional);
  }
  void Unlock(int64_t t = kT0) {
    ASSERT_EQ(Tx({0x10, 0x03}, t)[0], 0x50);
    const Bytes seed = Tx({0x27, 0x01}, t);
    ASSERT_EQ(seed.size(), 18u);
    uint8_t key[kKeySize];
    ASSERT_TRUE(ComputeKey(calibd::testing::kTestSecret, &seed[2], kSeedSize, key));
    Bytes send(2 + kKeySize);
    send[0] = 0x27;
    send[1] = 0x02;
    std::copy(key, key + kKeySize, send.begin() + 2);
    ASSERT_EQ(Tx(send, t), (Bytes{0x67, 0x02}));
  }

  TempDir dir_;
  UdsConfig config_;
  FakeUdsBackend backend_;
  std::unique_ptr<UdsServer> server_;
};

TEST(UdsConfigTest, DefaultsAndChecks) {
  UdsConfig c;
  std::string error;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_EQ(error, "uds.secret_file: must name the secret file");
  c.secret_file = "/etc/calibd/secret";
  c.state_dir = "/var/lib/calibd";
  EXPECT_TRUE(c.IsValid(&error)) << error;
  EXPECT_EQ(c.max_key_attempts, 3);
  EXPECT_EQ(c.lockout_delay_us, 10 * kS);
  EXPECT_EQ(c.s3_us, 5 * kS);
  EXPECT_EQ(c.p2_ms, 50);
  EXPECT_EQ(c.p2_star_ms, 5000);
  c.p2_star_ms = 5005;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_EQ(error, "uds.p2_star_ms: must be a multiple of 10 in [0, 655350] (got 5005)");
  c.p2_star_ms = 5000;
  c.ecu_serial = "01234567890123456";
  EXPECT_FALSE(c.IsValid(&error));
  c.ecu_serial = "ok";
  c.max_key_attempts = 0;
  EXPECT_FALSE(c.IsValid(&error));
}

TEST_F(UdsServerTest, SessionControlReportsP2AndP2StarInTheStandardsUnits) {
  // ISO 14229-1 §9.2.3: P2 = 50 ms -> 0x0032 (1 ms), P2* = 5000 ms -> 0x01F4 (10 ms).
  EXPECT_EQ(Tx({0x10, 0x03}), (Bytes{0x50, 0x03, 0x00, 0x32, 0x01, 0xF4}));
  EXPECT_EQ(server_->session(), Session::kExtended);
  EXPECT_EQ(Tx({0x10, 0x01}), (Bytes{0x50, 0x01, 0x00, 0x32, 0x01, 0xF4}));
  EXPECT_EQ(server_->session(), Session::kDefault);
}

TEST_F(UdsServerTest, SessionControlNrcs) {
  EXPECT_EQ(Tx({0x10, 0x02}), (Bytes{0x7F, 0x10, 0x12})) << "programming session";
  EXPECT_EQ(Tx({0x10, 0x04}), (Bytes{0x7F, 0x10, 0x12}));
  EXPECT_EQ(Tx({0x10}), (Bytes{0x7F, 0x10, 0x13}));
  EXPECT_EQ(Tx({0x10, 0x03, 0x00}), (Bytes{0x7F, 0x10, 0x13}));
  // Figure 6: the sub-function check comes before the exact length check.
  EXPECT_EQ(Tx({0x10, 0x05, 0x00}), (Bytes{0x7F, 0x10, 0x12}));
  EXPECT_EQ(server_->session(), Session::kDefault);
}

TEST_F(UdsServerTest, SuppressPositiveResponseBit) {
  EXPECT_EQ(Tx({0x10, 0x83}), Bytes{});
  EXPECT_EQ(server_->session(), Session::kExtended) << "suppressed, but done";
  EXPECT_EQ(Tx({0x3E, 0x00}), (Bytes{0x7E, 0x00}));
  EXPECT_EQ(Tx({0x3E, 0x80}), Bytes{});
  // Negative responses are never suppressed by the bit (§7.5.2).
  EXPECT_EQ(Tx({0x3E, 0x81}), (Bytes{0x7F, 0x3E, 0x12}));
  EXPECT_EQ(Tx({0x3E, 0x00, 0x00}), (Bytes{0x7F, 0x3E, 0x13}));
  EXPECT_EQ(Tx({0x3E}), (Bytes{0x7F, 0x3E, 0x13}));
  EXPECT_EQ(Tx({0x10, 0x81}), Bytes{});
  EXPECT_EQ(server_->session(), Session::kDefault);
}

// ISO 14229-2 §7.2: the requests that may wait for storage (each write fsync'd) are the ones the
// transport answers with 0x78 first; after a 0x78 the final positive response comes even when
// the request asked for none (ISO 14229-1 §7.5.2).
TEST_F(UdsServerTest, RequestsThatMayWriteStorageAndTheirAnswerAfterResponsePending) {
  auto writes = [](const Bytes& r) { return MayWriteStorage(r.data(), r.size()); };
  EXPECT_TRUE(writes({0x31, 0x01, 0xF0, 0xA1}));   // commit
  EXPECT_TRUE(writes({0x31, 0x81, 0xF0, 0xA2}));   // restore, positive response suppressed
  EXPECT_TRUE(writes({0x31, 0x02, 0xF0, 0xA0}));   // stop: the session marker goes
  EXPECT_FALSE(writes({0x31, 0x03, 0xF0, 0xA0}));  // results: read only
  EXPECT_TRUE(writes({0x27, 0x02, 0x00}));         // sendKey: the attempt counter
  EXPECT_FALSE(writes({0x27, 0x01}));              // requestSeed
  EXPECT_TRUE(writes({0x2E, 0xF1, 0x90}));         // the VIN
  EXPECT_TRUE(writes({0x14, 0xFF, 0xFF, 0xFF}));   // the DTC file
  EXPECT_FALSE(writes({0x22, 0xF1, 0x90}));
  EXPECT_FALSE(writes({0x3E, 0x00}));
  EXPECT_FALSE(writes({0x10, 0x03}));
  EXPECT_FALSE(MayWriteStorage(nullptr, 0));

  // Suppressed without a 0x78; with one, the final positive response is sent.
  const Bytes clear = {0x14, 0xFF, 0xFF, 0xFF};
  EXPECT_EQ(Tx(clear), (Bytes{0x54}));
  const Bytes suppressed = {0x10, 0x83};
  EXPECT_EQ(Tx(suppressed), Bytes{});
  const Response r = server_->Handle(suppressed.data(), suppressed.size(), false, kT0, true);
  EXPECT_EQ(Bytes(r.data, r.data + r.size), (Bytes{0x50, 0x03, 0x00, 0x32, 0x01, 0xF4}));
}

TEST_F(UdsServerTest, UnknownServiceAndServiceNotInSession) {
  EXPECT_EQ(Tx({0x23, 0x00}), (Bytes{0x7F, 0x23, 0x11}));
  EXPECT_EQ(Tx({0x7F}), (Bytes{0x7F, 0x7F, 0x11}));
  for (int s : {0x27, 0x2E, 0x31, 0x85}) {
    const auto sid = static_cast<uint8_t>(s);
    EXPECT_EQ(Tx({sid, 0x01, 0x02, 0x03, 0x04}), (Bytes{0x7F, sid, 0x7F})) << int(sid);
    // 0x7F (Figure 5) comes before any length check (Figure 6).
    EXPECT_EQ(Tx({sid}), (Bytes{0x7F, sid, 0x7F})) << int(sid);
  }
  EXPECT_TRUE(server_->Handle(nullptr, 0, false, kT0).empty());
}

TEST_F(UdsServerTest, FunctionalRequestsSuppressSomeNegativeResponses) {
  const bool functional = true;
  EXPECT_EQ(Tx({0x23, 0x00}, kT0, functional), Bytes{}) << "0x11";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0}, kT0, functional), Bytes{}) << "0x7F";
  EXPECT_EQ(Tx({0x10, 0x02}, kT0, functional), Bytes{}) << "0x12";
  EXPECT_EQ(Tx({0x22, 0x12, 0x34}, kT0, functional), Bytes{}) << "0x31";
  // Other NRCs and positive responses go out as usual.
  EXPECT_EQ(Tx({0x10, 0x03, 0x00}, kT0, functional), (Bytes{0x7F, 0x10, 0x13}));
  EXPECT_EQ(Tx({0x3E, 0x00}, kT0, functional), (Bytes{0x7E, 0x00}));
  EXPECT_EQ(Tx({0x3E, 0x80}, kT0, functional), Bytes{});
}

TEST_F(UdsServerTest, S3TimeoutReturnsToDefaultAbortsAndRelocks) {
  Unlock();
  ASSERT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x00, 0x00, 0x00}), (Bytes{0x71, 0x01, 0xF0, 0xA0, 0x01}));
  const int aborts = backend_.aborts;
  EXPECT_EQ(aborts, 0);
  server_->Tick(kT0 + 4 * kS);
  EXPECT_EQ(server_->session(), Session::kExtended);
  EXPECT_EQ(Tx({0x3E, 0x80}, kT0 + 4 * kS), Bytes{}) << "restarts S3";
  server_->Tick(kT0 + 8 * kS);
  EXPECT_EQ(server_->session(), Session::kExtended);
  EXPECT_TRUE(server_->security_unlocked());
  server_->Tick(kT0 + 9 * kS);
  EXPECT_EQ(server_->session(), Session::kDefault);
  EXPECT_FALSE(server_->security_unlocked());
  EXPECT_EQ(backend_.aborts, aborts + 1);
  EXPECT_EQ(backend_.snapshot.status, RoutineStatus::kAborted);
}

TEST_F(UdsServerTest, S3ExpiryIsSeenByTheNextRequestWithoutTick) {
  Unlock();
  // No Tick: the request after 5 s already finds the default session.
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA0}, kT0 + 5 * kS), (Bytes{0x7F, 0x31, 0x7F}));
  EXPECT_EQ(server_->session(), Session::kDefault);
  EXPECT_FALSE(server_->security_unlocked());
}

TEST_F(UdsServerTest, LeavingOrReenteringExtendedRelocksSecurity) {
  Unlock();
  EXPECT_EQ(Tx({0x10, 0x03})[0], 0x50);
  EXPECT_FALSE(server_->security_unlocked());
  Unlock();
  EXPECT_EQ(Tx({0x10, 0x01})[0], 0x50);
  EXPECT_FALSE(server_->security_unlocked());
  EXPECT_EQ(backend_.aborts, 0) << "no routine was started in that session";
  Unlock();
  ASSERT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x00, 0x00, 0x00})[0], 0x71);
  EXPECT_EQ(Tx({0x10, 0x03})[0], 0x50);
  EXPECT_EQ(backend_.aborts, 0) << "re-entering extended keeps the routine running";
  EXPECT_EQ(Tx({0x10, 0x01})[0], 0x50);
  EXPECT_EQ(backend_.aborts, 1) << "entering default aborts the routine";
  EXPECT_EQ(backend_.snapshot.status, RoutineStatus::kAborted);
  EXPECT_EQ(Tx({0x10, 0x01})[0], 0x50);
  EXPECT_EQ(backend_.aborts, 1);
}

TEST_F(UdsServerTest, EcuResetHardResetOnly) {
  EXPECT_EQ(Tx({0x11, 0x01}), (Bytes{0x51, 0x01}));
  EXPECT_EQ(backend_.resets, 1);
  EXPECT_EQ(Tx({0x11, 0x81}), Bytes{});
  EXPECT_EQ(backend_.resets, 2);
  EXPECT_EQ(Tx({0x11, 0x03}), (Bytes{0x7F, 0x11, 0x12}));
  EXPECT_EQ(Tx({0x11, 0x02}), (Bytes{0x7F, 0x11, 0x12}));
  EXPECT_EQ(Tx({0x11, 0x01, 0x00}), (Bytes{0x7F, 0x11, 0x13}));
  EXPECT_EQ(Tx({0x11}), (Bytes{0x7F, 0x11, 0x13}));
  EXPECT_EQ(backend_.resets, 2);
}

Bytes Ascii(const std::string& s, size_t size) {
  Bytes b(s.begin(), s.end());
  b.resize(size, ' ');
  return b;
}

Bytes Concat(std::initializer_list<Bytes> parts) {
  Bytes out;
  for (const Bytes& p : parts) out.insert(out.end(), p.begin(), p.end());
  return out;
}

TEST_F(UdsServerTest, ReadDataByIdentifierIdentification) {
  EXPECT_EQ(Tx({0x22, 0xF1, 0x90}), Concat({{0x62, 0xF1, 0x90}, Ascii("WVWZZZ1KZAW000001", 17)}));
  EXPECT_EQ(Tx({0x22, 0xF1, 0x8C, 0xF1, 0x95}),
            Concat({{0x62, 0xF1, 0x8C}, Ascii("ECU-0001", 16), {0xF1, 0x95}, Ascii("0.6.0", 16)}));
  EXPECT_EQ(
      Tx({0x22, 0xFD, 0x03, 0xFD, 0x04}),
      Concat({{0x62, 0xFD, 0x03}, Ascii("OT128-0042", 32), {0xFD, 0x04}, Ascii("CAM-7", 32)}));
  // 2023-11-14 22:13:20 UTC.
  backend_.calibration_unix_s = 1'700'000'000;
  EXPECT_EQ(Tx({0x22, 0xF1, 0x9B}), (Bytes{0x62, 0xF1, 0x9B, 0x20, 0x23, 0x11, 0x14}));
  backend_.calibration_unix_s = 0;
  EXPECT_EQ(Tx({0x22, 0xF1, 0x9B}), (Bytes{0x62, 0xF1, 0x9B, 0x00, 0x00, 0x00, 0x00}));
}

TEST_F(UdsServerTest, ReadDataByIdentifierSupplierScalings) {
  backend_.current = {true, 0.1, -0.02, 0.003, 1.5, -0.25, 90.0};
  // x 0.1 m = 10000 x 0.01 mm; y -2000; z 300; roll 1500000 udeg; pitch -250000; yaw 90000000.
  EXPECT_EQ(Tx({0x22, 0xFD, 0x00}), (Bytes{0x62, 0xFD, 0x00, 0x00, 0x00, 0x27, 0x10, 0xFF, 0xFF,
                                           0xF8, 0x30, 0x00, 0x00, 0x01, 0x2C, 0x00, 0x16, 0xE3,
                                           0x60, 0xFF, 0xFC, 0x2F, 0x70, 0x05, 0x5D, 0x4A, 0x80}));
  Bytes unavailable(3 + kExtrinsicSize, 0xFF);  // 6 x 0x7FFFFFFF: not available
  unavailable[0] = 0x62;
  unavailable[1] = 0xFD;
  unavailable[2] = 0x01;
  for (size_t i = 0; i < 6; ++i) unavailable[3 + 4 * i] = 0x7F;
  EXPECT_EQ(Tx({0x22, 0xFD, 0x01}), unavailable);
  backend_.quality = {3.23, 0.0259, 0.012, 0.0011, 200, 600, 0.0834, 0.0127};
  // 323 (0.01 px), 259 (0.1 mm), 12 (0.001 deg), 11 (0.1 mm), 200, 600, then the error bound:
  // 83 (0.001 deg), 127 (0.1 mm).
  EXPECT_EQ(Tx({0x22, 0xFD, 0x02}),
            (Bytes{0x62, 0xFD, 0x02, 0x01, 0x43, 0x01, 0x03, 0x00, 0x0C, 0x00, 0x0B, 0x00, 0xC8,
                   0x02, 0x58, 0x00, 0x53, 0x00, 0x7F}));
  backend_.quality.rotation_bound_deg = backend_.quality.translation_bound_m = 0.0;  // unknown
  EXPECT_EQ(Tx({0x22, 0xFD, 0x02}),
            (Bytes{0x62, 0xFD, 0x02, 0x01, 0x43, 0x01, 0x03, 0x00, 0x0C, 0x00, 0x0B, 0x00, 0xC8,
                   0x02, 0x58, 0xFF, 0xFF, 0xFF, 0xFF}));
  backend_.state = CalibrationState::kRecalibrationRequired;
  backend_.snapshot.status = RoutineStatus::kActive;
  EXPECT_EQ(Tx({0x22, 0xFD, 0x05}), (Bytes{0x62, 0xFD, 0x05, 0x02, 0x01}));
  // Capture coverage: static session, bins 0 and 2 seen of 3 needed, cells 0, 5 and 15 of 4
  // needed, 37 of 50 frame pairs (target 200), 70000 boards (saturates at 0xFFFF) of 20.
  backend_.coverage.moving = false;
  backend_.coverage.distance_bins = 0b101;
  backend_.coverage.image_cells = (1u << 0) | (1u << 5) | (1u << 15);
  backend_.coverage.frames_with_boards = 37;
  backend_.coverage.boards = 70000;
  backend_.coverage.gates = {200, 50, 20, 3, 4};  // target, frames, boards, bins, cells
  const Bytes coverage{0x62, 0xFD, 0x06, 0x01, 0x05, 0x03, 0x80, 0x21, 0x04, 0x00,
                       0x25, 0x00, 0x32, 0x00, 0xC8, 0xFF, 0xFF, 0x00, 0x14};
  EXPECT_EQ(Tx({0x22, 0xFD, 0x06}), coverage);
  const CaptureCoverage back = DecodeCoverage(coverage.data() + 3);
  EXPECT_FALSE(back.moving);
  EXPECT_EQ(back.distance_bins, 0b101u);
  EXPECT_EQ(back.image_cells, backend_.coverage.image_cells);
  EXPECT_EQ(back.frames_with_boards, 37);
  EXPECT_EQ(back.boards, 0xFFFF);
  EXPECT_EQ(back.gates.min_boards, 20);
}

TEST(DidCodecTest, ScalingSaturatesAndRounds) {
  EXPECT_EQ(ScaleToInt32(1e9, kTranslationLsbM), INT32_MAX);
  EXPECT_EQ(ScaleToInt32(-1e9, kTranslationLsbM), INT32_MIN);
  EXPECT_EQ(ScaleToUint16(-1.0, kLengthFigureLsbM), 0);
  EXPECT_EQ(ScaleToUint16(70.0, kRotationFigureLsbDeg), 0xFFFF);
  EXPECT_EQ(ScaleToUint16(0.00016, kLengthFigureLsbM), 2) << "rounds to nearest";
  EXPECT_EQ(ScaleToUint16(0.00014, kLengthFigureLsbM), 1);
  EXPECT_EQ(ScaleToInt32(std::nan(""), kAngleLsbDeg), 0);
}

TEST_F(UdsServerTest, ReadDataByIdentifierNrcs) {
  EXPECT_EQ(Tx({0x22}), (Bytes{0x7F, 0x22, 0x13}));
  EXPECT_EQ(Tx({0x22, 0xF1}), (Bytes{0x7F, 0x22, 0x13}));
  EXPECT_EQ(Tx({0x22, 0xF1, 0x90, 0xF1}), (Bytes{0x7F, 0x22, 0x13}));
  EXPECT_EQ(Tx({0x22, 0x12, 0x34}), (Bytes{0x7F, 0x22, 0x31}));
  // An unsupported DID among supported ones is left out (§10.2.1).
  EXPECT_EQ(Tx({0x22, 0x12, 0x34, 0xFD, 0x05}), (Bytes{0x62, 0xFD, 0x05, 0x01, 0x00}));
  Bytes many(1 + 2 * (kMaxDidsPerRead + 1), 0xFD);
  many[0] = 0x22;
  for (size_t i = 0; i <= kMaxDidsPerRead; ++i) many[2 + 2 * i] = 0x05;
  EXPECT_EQ(Tx(many), (Bytes{0x7F, 0x22, 0x13}));
}

TEST_F(UdsServerTest, WriteVinNeedsExtendedSessionAndSecurity) {
  const Bytes vin = Ascii("1HGCM82633A004352", 17);
  const Bytes write = Concat({{0x2E, 0xF1, 0x90}, vin});
  EXPECT_EQ(Tx(write), (Bytes{0x7F, 0x2E, 0x7F}));
  ASSERT_EQ(Tx({0x10, 0x03})[0], 0x50);
  EXPECT_EQ(Tx(write), (Bytes{0x7F, 0x2E, 0x33}));
  // Order: the DID check (0x31) before security (0x33); security before the length (0x13).
  EXPECT_EQ(Tx(Concat({{0x2E, 0xF1, 0x8C}, vin})), (Bytes{0x7F, 0x2E, 0x31}));
  EXPECT_EQ(Tx({0x2E, 0xF1, 0x90, 0x41}), (Bytes{0x7F, 0x2E, 0x33}));
  EXPECT_EQ(Tx({0x2E, 0xF1, 0x90}), (Bytes{0x7F, 0x2E, 0x13}));
  Unlock();
  EXPECT_EQ(Tx({0x2E, 0xF1, 0x90, 0x41}), (Bytes{0x7F, 0x2E, 0x13}));
  EXPECT_EQ(Tx(Concat({{0x2E, 0xF1, 0x90}, Ascii("1HGCM82633A00435O", 17)})),
            (Bytes{0x7F, 0x2E, 0x31}))
      << "O is not a VIN character";
  EXPECT_EQ(Tx(write), (Bytes{0x6E, 0xF1, 0x90}));
  EXPECT_EQ(backend_.written_vin, "1HGCM82633A004352");
  backend_.write_vin_ok = false;
  EXPECT_EQ(Tx(write), (Bytes{0x7F, 0x2E, 0x72}));
}

}  // namespace
}  // namespace calibd::uds
