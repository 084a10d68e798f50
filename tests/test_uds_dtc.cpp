// UdsServer DTC services: ReadDTCInformation 0x19 (01, 02, 04, 06, 0A), ClearDiagnosticInformation
// 0x14, ControlDTCSetting 0x85, and the DtcStore's status bits (ISO 14229-1 Annex D.2) persisted
// in the state directory.

#include <gtest/gtest.h>

#include <cstdint>
#include <fstream>
#include <memory>
#include <vector>

#include "calibd/agent/uds/dtc_store.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "temp_dir.hpp"
#include "uds_fake_backend.hpp"

namespace calibd::uds {
namespace {

using namespace calibd::testing::uds_test;  // NOLINT(google-build-using-namespace)

class UdsDtcTest : public ::testing::Test {
 protected:
  void SetUp() override {
    config_ = calibd::testing::TestUdsConfig(dir_.path().string());
    Restart();
  }
  void Restart() {
    server_ = std::make_unique<UdsServer>(config_, &backend_);
    std::string error;
    ASSERT_TRUE(server_->Init(kT0, kUnix0, &error)) << error;
  }
  Bytes Tx(const Bytes& request) { return Send(*server_, request, kT0); }
  void Report(Dtc dtc, bool failed) {
    std::string error;
    ASSERT_TRUE(server_->dtcs().Report(dtc, failed, &error)) << error;
  }

  TempDir dir_;
  UdsConfig config_;
  FakeUdsBackend backend_;
  std::unique_ptr<UdsServer> server_;
};

Bytes AllSupported(uint8_t status) {
  Bytes r = {0x59, 0x0A, 0x7F};
  for (uint32_t n : kDtcNumbers) {
    r.insert(r.end(), {static_cast<uint8_t>(n >> 16), static_cast<uint8_t>(n >> 8),
                       static_cast<uint8_t>(n), status});
  }
  return r;
}

TEST_F(UdsDtcTest, FreshStoreReportsEverySupportedDtcNotCompleted) {
  // After a clear and a new operation cycle: testNotCompletedSinceLastClear | ...ThisCycle.
  EXPECT_EQ(Tx({0x19, 0x0A}), AllSupported(0x50));
  EXPECT_EQ(Tx({0x19, 0x01, 0x09}), (Bytes{0x59, 0x01, 0x7F, 0x00, 0x00, 0x00}));
  EXPECT_EQ(Tx({0x19, 0x02, 0x09}), (Bytes{0x59, 0x02, 0x7F}));
}

TEST_F(UdsDtcTest, FailedTestSetsTheAnnexDBits) {
  Report(Dtc::kLidarTimeout, true);
  // testFailed | ThisOperationCycle | pending | confirmed | testFailedSinceLastClear = 0x2F.
  EXPECT_EQ(server_->dtcs().status(Dtc::kLidarTimeout), 0x2F);
  EXPECT_EQ(Tx({0x19, 0x01, 0x08}), (Bytes{0x59, 0x01, 0x7F, 0x00, 0x00, 0x01}));
  EXPECT_EQ(Tx({0x19, 0x02, 0x08}), (Bytes{0x59, 0x02, 0x7F, 0x5A, 0x01, 0x87, 0x2F}));
  EXPECT_EQ(Tx({0x19, 0x82, 0x08}), Bytes{}) << "suppress bit";
  Report(Dtc::kLidarTimeout, false);
  EXPECT_EQ(server_->dtcs().status(Dtc::kLidarTimeout), 0x2E);
  EXPECT_EQ(Tx({0x19, 0x02, 0x01}), (Bytes{0x59, 0x02, 0x7F}));
  // A passed test clears the "not completed" bits only.
  Report(Dtc::kCameraTimeout, false);
  EXPECT_EQ(server_->dtcs().status(Dtc::kCameraTimeout), 0x00);
}

TEST_F(UdsDtcTest, StatusPersistsAndOperationCyclesAge) {
  Report(Dtc::kCanBusOff, true);
  Restart();
  // New cycle: ThisOperationCycle cleared, NotCompletedThisOperationCycle set; still pending.
  EXPECT_EQ(server_->dtcs().status(Dtc::kCanBusOff), 0x6D);
  EXPECT_EQ(Tx({0x19, 0x02, 0x08}), (Bytes{0x59, 0x02, 0x7F, 0xC0, 0x01, 0x88, 0x6D}));
  Report(Dtc::kCanBusOff, false);
  EXPECT_EQ(server_->dtcs().status(Dtc::kCanBusOff), 0x2C);
  Restart();
  // A cycle that completed without failing clears pendingDTC; confirmed stays until cleared.
  EXPECT_EQ(server_->dtcs().status(Dtc::kCanBusOff), 0x68);
  EXPECT_TRUE(server_->warnings().empty()) << server_->warnings();
}

TEST_F(UdsDtcTest, ClearIsPersisted) {
  Report(Dtc::kStoreCorrupt, true);
  EXPECT_EQ(Tx({0x14, 0xFF, 0xFF, 0xFF}), (Bytes{0x54}));
  EXPECT_EQ(Tx({0x19, 0x0A}), AllSupported(0x50));
  Restart();
  EXPECT_EQ(Tx({0x19, 0x0A}), AllSupported(0x50));
  EXPECT_EQ(Tx({0x14, 0xFF, 0xFF}), (Bytes{0x7F, 0x14, 0x13}));
  EXPECT_EQ(Tx({0x14, 0x5A, 0x00, 0x46}), (Bytes{0x7F, 0x14, 0x31}));
}

TEST_F(UdsDtcTest, DtcSettingOffFreezesStatus) {
  EXPECT_EQ(Tx({0x85, 0x02}), (Bytes{0x7F, 0x85, 0x7F})) << "extended session only";
  ASSERT_EQ(Tx({0x10, 0x03})[0], 0x50);
  EXPECT_EQ(Tx({0x85, 0x02}), (Bytes{0xC5, 0x02}));
  Report(Dtc::kResultRejected, true);
  EXPECT_EQ(server_->dtcs().status(Dtc::kResultRejected), 0x50);
  EXPECT_EQ(Tx({0x85, 0x81}), Bytes{});
  Report(Dtc::kResultRejected, true);
  EXPECT_EQ(server_->dtcs().status(Dtc::kResultRejected), 0x2F);
  EXPECT_EQ(Tx({0x85, 0x02}), (Bytes{0xC5, 0x02}));
  EXPECT_EQ(Tx({0x10, 0x01})[0], 0x50);
  EXPECT_TRUE(server_->dtcs().enabled()) << "the default session turns DTC setting back on";
  ASSERT_EQ(Tx({0x10, 0x03})[0], 0x50);
  EXPECT_EQ(Tx({0x85, 0x03}), (Bytes{0x7F, 0x85, 0x12}));
  EXPECT_EQ(Tx({0x85, 0x01, 0xFF, 0xFF, 0xFF}), (Bytes{0x7F, 0x85, 0x13}));
}

TEST_F(UdsDtcTest, SnapshotAndExtendedDataRecords) {
  Report(Dtc::kCalibrationNotPerformed, true);
  // No snapshot / extended data is kept: DTC and status only.
  EXPECT_EQ(Tx({0x19, 0x04, 0x5A, 0x00, 0x54, 0xFF}), (Bytes{0x59, 0x04, 0x5A, 0x00, 0x54, 0x2F}));
  EXPECT_EQ(Tx({0x19, 0x06, 0x5A, 0x00, 0x54, 0x01}), (Bytes{0x59, 0x06, 0x5A, 0x00, 0x54, 0x2F}));
  EXPECT_EQ(Tx({0x19, 0x04, 0x12, 0x34, 0x56, 0xFF}), (Bytes{0x7F, 0x19, 0x31}));
  EXPECT_EQ(Tx({0x19, 0x06, 0x5A, 0x00, 0x54, 0x02}), (Bytes{0x7F, 0x19, 0x31}));
  EXPECT_EQ(Tx({0x19, 0x04, 0x5A, 0x00, 0x54}), (Bytes{0x7F, 0x19, 0x13}));
  EXPECT_EQ(Tx({0x19, 0x03}), (Bytes{0x7F, 0x19, 0x12}));
  EXPECT_EQ(Tx({0x19, 0x02}), (Bytes{0x7F, 0x19, 0x13}));
  EXPECT_EQ(Tx({0x19}), (Bytes{0x7F, 0x19, 0x13}));
}

TEST_F(UdsDtcTest, CorruptFileIsReportedAndStartsCleared) {
  std::ofstream(config_.state_dir + "/dtc_status") << "calibd-dtc 1\n5A0054 2F\n";  // truncated
  Restart();
  EXPECT_NE(server_->warnings().find("dtc_status: corrupt"), std::string::npos);
  EXPECT_EQ(Tx({0x19, 0x0A}), AllSupported(0x50));
}

// A file written before 5A0044 (store write failed) existed: its DTCs keep their status, the new
// one starts cleared, and it is not taken for a corrupt file.
TEST_F(UdsDtcTest, FileWithoutALaterDtcKeepsTheOthers) {
  std::ofstream(config_.state_dir + "/dtc_status")
      << "calibd-dtc 1\n5A0054 2F\n5A0064 50\n5A0056 50\n5A0187 50\n5A0287 50\n5A0046 50\n"
         "C00188 50\nend\n";
  Restart();
  EXPECT_TRUE(server_->warnings().empty()) << server_->warnings();
  EXPECT_EQ(server_->dtcs().status(Dtc::kCalibrationNotPerformed), 0x6D);
  EXPECT_EQ(server_->dtcs().status(Dtc::kStoreWriteFailed), 0x50);
  // The same DTC twice is not what the agent writes.
  std::ofstream(config_.state_dir + "/dtc_status") << "calibd-dtc 1\n5A0054 2F\n5A0054 2F\nend\n";
  Restart();
  EXPECT_NE(server_->warnings().find("dtc_status: corrupt"), std::string::npos);
}

// 5A0300 (C1A03-00, calibration session interrupted): its number, its name in the tester, and its
// status across a restart like any other; a file written before it existed loads without it.
TEST_F(UdsDtcTest, SessionInterruptedPersistsAndPasses) {
  EXPECT_EQ(kDtcNumbers[static_cast<size_t>(Dtc::kSessionInterrupted)], 0x5A0300u);
  EXPECT_EQ(DtcStore::IndexOf(0x5A0300), static_cast<int>(Dtc::kSessionInterrupted));
  Report(Dtc::kSessionInterrupted, true);
  EXPECT_EQ(server_->dtcs().status(Dtc::kSessionInterrupted), 0x2F);
  Restart();  // the agent restarted: a new operation cycle
  EXPECT_EQ(server_->dtcs().status(Dtc::kSessionInterrupted), 0x6D);
  EXPECT_EQ(Tx({0x19, 0x02, 0x01}), (Bytes{0x59, 0x02, 0x7F, 0x5A, 0x03, 0x00, 0x6D}));
  Report(Dtc::kSessionInterrupted, false);  // the next session ended with a result
  EXPECT_EQ(server_->dtcs().status(Dtc::kSessionInterrupted), 0x2C);
  std::ofstream(config_.state_dir + "/dtc_status")
      << "calibd-dtc 1\n5A0054 2F\n5A0064 50\n5A0056 50\n5A0187 50\n5A0287 50\n5A0046 50\n"
         "C00188 50\n5A0044 50\nend\n";
  Restart();
  EXPECT_TRUE(server_->warnings().empty()) << server_->warnings();
  EXPECT_EQ(server_->dtcs().status(Dtc::kSessionInterrupted), 0x50);
}

}  // namespace
}  // namespace calibd::uds
