// UdsServer RoutineControl 0x31 (ISO 14229-1 §13.2): calibrate / verify / commit / restore,
// start-poll-stop flows and the NRC order, byte for byte.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <memory>
#include <vector>

#include "calibd/agent/uds/security_access.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "temp_dir.hpp"
#include "uds_fake_backend.hpp"

namespace calibd::uds {
namespace {

using namespace calibd::testing::uds_test;  // NOLINT(google-build-using-namespace)

const Bytes kStartCalibrate = {0x31, 0x01, 0xF0, 0xA0, 0x00, 0x00, 0x3C};  // moving, 60 s
const Bytes kResults = {0x31, 0x03, 0xF0, 0xA0};

class UdsRoutineTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = calibd::testing::TestUdsConfig(dir_.path().string());
    server_ = std::make_unique<UdsServer>(config_, &backend_);
    std::string error;
    ASSERT_TRUE(server_->Init(kT0, kUnix0, &error)) << error;
    ASSERT_EQ(Tx({0x10, 0x03})[0], 0x50);
  }
  Bytes Tx(const Bytes& request) { return Send(*server_, request, kT0); }
  void Unlock() {
    const Bytes seed = Tx({0x27, 0x01});
    ASSERT_EQ(seed.size(), 18u);
    uint8_t key[kKeySize];
    ASSERT_TRUE(ComputeKey(calibd::testing::kTestSecret, &seed[2], kSeedSize, key));
    Bytes send(2 + kKeySize);
    send[0] = 0x27;
    send[1] = 0x02;
    std::copy(key, key + kKeySize, send.begin() + 2);
    ASSERT_EQ(Tx(send), (Bytes{0x67, 0x02}));
  }

  TempDir dir_;
  UdsConfig config_;
  FakeUdsBackend backend_;
  std::unique_ptr<UdsServer> server_;
};

TEST_F(UdsRoutineTest, CalibrateStartPollFinish) {
  Unlock();
  EXPECT_EQ(Tx(kStartCalibrate), (Bytes{0x71, 0x01, 0xF0, 0xA0, 0x01}));
  EXPECT_EQ(backend_.starts, 1);
  EXPECT_EQ(backend_.last_options.mode, CalibrationMode::kMoving);
  EXPECT_EQ(backend_.last_options.max_duration_s, 60);
  EXPECT_FALSE(backend_.last_options.verify_only);
  backend_.snapshot.progress_percent = 42;
  EXPECT_EQ(Tx(kResults),
            (Bytes{0x71, 0x03, 0xF0, 0xA0, 0x01, 42, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00}));
  backend_.snapshot = {RoutineStatus::kSuccess, 100, RoutineVerdict::kUpdated,
                       Reason::kNone,           5.0, 0.05};
  // 5 deg = 5000 x 0.001 deg = 0x1388; 0.05 m = 500 x 0.1 mm = 0x01F4.
  EXPECT_EQ(Tx(kResults),
            (Bytes{0x71, 0x03, 0xF0, 0xA0, 0x02, 100, 0x02, 0x00, 0x13, 0x88, 0x01, 0xF4}));
  backend_.snapshot = {RoutineStatus::kFailed, 90,  RoutineVerdict::kNone,
                       Reason::kTooFewBoards,  0.0, 0.0};
  EXPECT_EQ(Tx(kResults),
            (Bytes{0x71, 0x03, 0xF0, 0xA0, 0x04, 90, 0x00, 0x04, 0x00, 0x00, 0x00, 0x00}));
}

TEST_F(UdsRoutineTest, CalibrateStop) {
  Unlock();
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA0}), (Bytes{0x7F, 0x31, 0x24})) << "nothing running";
  ASSERT_EQ(Tx(kStartCalibrate)[0], 0x71);
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA0, 0x00}), (Bytes{0x7F, 0x31, 0x13}));
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA0}), (Bytes{0x71, 0x02, 0xF0, 0xA0, 0x03}));
  EXPECT_EQ(backend_.stops, 1);
  EXPECT_EQ(Tx(kResults),
            (Bytes{0x71, 0x03, 0xF0, 0xA0, 0x03, 0, 0x00, 0x01, 0x00, 0x00, 0x00, 0x00}));
}

TEST_F(UdsRoutineTest, VerifyIsACalibrationThatIsNotCommitted) {
  Unlock();
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA3, 0x01, 0x01, 0x2C}), (Bytes{0x71, 0x01, 0xF0, 0xA3, 0x01}));
  EXPECT_TRUE(backend_.last_options.verify_only);
  EXPECT_EQ(backend_.last_options.mode, CalibrationMode::kStatic);
  EXPECT_EQ(backend_.last_options.max_duration_s, 300);
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA3})[0], 0x71);
}

TEST_F(UdsRoutineTest, SuppressBitStartsWithoutReply) {
  Unlock();
  EXPECT_EQ(Tx({0x31, 0x81, 0xF0, 0xA0, 0x00, 0x00, 0x00}), Bytes{});
  EXPECT_EQ(backend_.starts, 1);
}

TEST_F(UdsRoutineTest, CommitAndRestore) {
  Unlock();
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA1}), (Bytes{0x7F, 0x31, 0x24})) << "results before start";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA1}), (Bytes{0x71, 0x01, 0xF0, 0xA1, 0x02}));
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA1}), (Bytes{0x71, 0x03, 0xF0, 0xA1, 0x02}));
  backend_.commit_reply = BackendReply::kSequenceError;  // nothing left to commit
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA1}), (Bytes{0x7F, 0x31, 0x24}));
  backend_.commit_reply = BackendReply::kFailure;  // the store write failed
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA1}), (Bytes{0x7F, 0x31, 0x72}));
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA1}), (Bytes{0x71, 0x03, 0xF0, 0xA1, 0x04}));
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA1, 0x00}), (Bytes{0x7F, 0x31, 0x13}));
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA1}), (Bytes{0x7F, 0x31, 0x12})) << "commit has no stop";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA2}), (Bytes{0x71, 0x01, 0xF0, 0xA2, 0x02}));
  EXPECT_EQ(backend_.restores, 1);
  backend_.conditions.interlock_asserted = false;
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA2}), (Bytes{0x7F, 0x31, 0x22}));
}

// The end-of-line line's provisioning: the current calibration kept as the reference (F0A4),
// unlocked only, with its own last-start status.
TEST_F(UdsRoutineTest, StoreReferenceKeepsTheCurrentAsTheReference) {
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x33})) << "locked";
  EXPECT_EQ(backend_.references_stored, 0);
  Unlock();
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x24})) << "results before start";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA4}), (Bytes{0x71, 0x01, 0xF0, 0xA4, 0x02}));
  EXPECT_EQ(backend_.references_stored, 1);
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA4}), (Bytes{0x71, 0x03, 0xF0, 0xA4, 0x02}));
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA2}), (Bytes{0x7F, 0x31, 0x24})) << "restore's own status";
  backend_.store_reference_reply = BackendReply::kConditionsNotCorrect;  // no current
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x22}));
  backend_.store_reference_reply = BackendReply::kFailure;  // the store write failed
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x72}));
  EXPECT_EQ(Tx({0x31, 0x03, 0xF0, 0xA4}), (Bytes{0x71, 0x03, 0xF0, 0xA4, 0x04}));
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x12})) << "no stop";
  backend_.conditions.interlock_asserted = false;
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA4}), (Bytes{0x7F, 0x31, 0x22}));
}

TEST_F(UdsRoutineTest, NrcsInTheStandardsOrder) {
  // Locked. Sub-function (0x12) and routine id (0x31) come before security (0x33).
  EXPECT_EQ(Tx({0x31}), (Bytes{0x7F, 0x31, 0x13}));
  EXPECT_EQ(Tx({0x31, 0x04, 0xF0, 0xA0}), (Bytes{0x7F, 0x31, 0x12}));
  EXPECT_EQ(Tx({0x31, 0x04}), (Bytes{0x7F, 0x31, 0x12})) << "0x12 before the RID length";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0}), (Bytes{0x7F, 0x31, 0x13}));
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xB0}), (Bytes{0x7F, 0x31, 0x31}));
  EXPECT_EQ(Tx(kStartCalibrate), (Bytes{0x7F, 0x31, 0x33}));
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0}), (Bytes{0x7F, 0x31, 0x33})) << "0x33 before 0x13";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA1}), (Bytes{0x7F, 0x31, 0x33}));
  EXPECT_EQ(Tx({0x31, 0x02, 0xF0, 0xA0}), (Bytes{0x7F, 0x31, 0x33}));
  // Results need no security, but a start first (0x24).
  EXPECT_EQ(Tx(kResults), (Bytes{0x7F, 0x31, 0x24}));
  Unlock();
  EXPECT_EQ(Tx(kResults), (Bytes{0x7F, 0x31, 0x24}));
  // Length (0x13) before option range (0x31) before conditions (0x22).
  backend_.conditions.interlock_asserted = false;
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x00, 0x00}), (Bytes{0x7F, 0x31, 0x13}));
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x02, 0x00, 0x00}), (Bytes{0x7F, 0x31, 0x31}));
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x00, 0x0E, 0x11}), (Bytes{0x7F, 0x31, 0x31})) << "3601 s";
  EXPECT_EQ(Tx({0x31, 0x01, 0xF0, 0xA0, 0x00, 0x0E, 0x10}), (Bytes{0x7F, 0x31, 0x22}));
  backend_.conditions = {true, false, true};
  EXPECT_EQ(Tx(kStartCalibrate), (Bytes{0x7F, 0x31, 0x22})) << "LiDAR silent";
  backend_.conditions = {true, true, false};
  EXPECT_EQ(Tx(kStartCalibrate), (Bytes{0x7F, 0x31, 0x22})) << "camera silent";
  backend_.conditions = {true, true, true};
  backend_.start_reply = BackendReply::kConditionsNotCorrect;  // a session already running
  EXPECT_EQ(Tx(kStartCalibrate), (Bytes{0x7F, 0x31, 0x22}));
  EXPECT_EQ(backend_.starts, 0);
  // Functional: 0x12 and 0x31 are not answered; 0x33/0x22 are.
  EXPECT_EQ(Send(*server_, {0x31, 0x01, 0xF0, 0xB0}, kT0, true), Bytes{});
  EXPECT_EQ(Send(*server_, kStartCalibrate, kT0, true), (Bytes{0x7F, 0x31, 0x22}));
}

}  // namespace
}  // namespace calibd::uds
