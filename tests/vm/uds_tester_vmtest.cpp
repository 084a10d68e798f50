// Inside the test VM (real vcan0 + can-isotp): calibd-tester (tools/tester) against a real
// UdsServer on a UdsServerTransport, served from a thread of this test with the fake backend of
// tests/uds_fake_backend.hpp. The tester runs as its own executable: outputs and exit codes are
// what a workshop sees. One case drives the tester library directly (P2* after 0x78).
//
// Where the executable comes from: the guest sees the host's root filesystem except /tmp, where a
// build tree may live (CI's clean clone); run_gtest.sh copies this test binary into the shared
// folder, and tests/CMakeLists.txt copies calibd-tester into the same folder at build time, so the
// test finds it beside itself (/proc/self/exe). Outside the VM it falls back to the build tree's.
// The secret file and the state directory are made under the guest's own /tmp: LoadSecret checks
// the owner and the mode, which a 9p shared folder reports as the host's security model decides.

#include <gtest/gtest.h>
#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <memory>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include "calibd/agent/uds/uds_server.hpp"
#include "calibd/drivers/isotp_channel.hpp"
#include "run_command.hpp"
#include "uds_client.hpp"
#include "uds_fake_backend.hpp"

namespace calibd {
namespace {

using testing::FakeUdsBackend;
using testing::TempDir;

constexpr char kInterface[] = "vcan0";
constexpr int64_t kSecondUs = 1000 * 1000;

std::string TesterExe() {
  std::error_code ec;
  const auto self = std::filesystem::read_symlink("/proc/self/exe", ec);
  const auto beside = self.parent_path() / "calibd-tester";
  if (!ec && std::filesystem::exists(beside)) return beside.string();
  return CALIBD_TESTER_EXE;
}

std::string ReadFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

struct TesterRun {
  int code = -1;
  std::string out, err;
};

/// A UdsServer on vcan0 in a thread: poll on the transport's fds, Handle, Send, Tick. The fake
/// backend's calibration advances 25 % every step_us once started and then finishes with
/// `final_verdict`. Test code reads the backend and server only after Stop().
class ServerThread {
 public:
  explicit ServerThread(const std::string& dir) : config_(testing::TestUdsConfig(dir)) {}
  ~ServerThread() { Stop(); }

  /// Starts serving (a fatal test failure when the server or the transport cannot start).
  void Start() {
    server_ = std::make_unique<uds::UdsServer>(config_, &backend);
    std::string error;
    const int64_t now = tester::MonotonicUs();
    ASSERT_TRUE(server_->Init(now, now, &error)) << error;
    if (report_lidar_timeout) {
      ASSERT_TRUE(server_->dtcs().Report(uds::Dtc::kLidarTimeout, true, &error)) << error;
    }
    IsoTpConfig isotp;
    isotp.interface = kInterface;
    ASSERT_TRUE(transport_.Start(isotp, now, &error)) << error;
    ASSERT_GE(transport_.physical_fd(), 0) << transport_.status().last_error;
    stop_ = false;
    thread_ = std::thread([this] { Loop(); });
  }
  void Stop() {
    stop_ = true;
    if (thread_.joinable()) thread_.join();
    transport_.Stop();
  }
  uds::UdsServer& server() { return *server_; }

  FakeUdsBackend backend;
  uds::RoutineVerdict final_verdict = uds::RoutineVerdict::kUpdated;
  bool report_lidar_timeout = false;
  int64_t step_us = 100000;  ///< between the fake calibration's 25 % steps

 private:
  void Loop() {
    int64_t last_step_us = 0;
    while (!stop_) {
      pollfd fds[2] = {{transport_.physical_fd(), POLLIN, 0},
                       {transport_.functional_fd(), POLLIN, 0}};
      ::poll(fds, 2, 10);
      const int64_t now = tester::MonotonicUs();
      IsoTpMessage request;
      while (transport_.Receive(&request) == IsoTpIo::kOk) {
        const uds::Response r =
            server_->Handle(request.data, request.size, request.functional, now);
        if (!r.empty()) transport_.Send(r.data, r.size);
      }
      transport_.Tick(now);
      server_->Tick(now);
      uds::RoutineSnapshot& s = backend.snapshot;
      if (s.status == uds::RoutineStatus::kActive && now - last_step_us >= step_us) {
        last_step_us = now;
        s.progress_percent = static_cast<uint8_t>(std::min(100, s.progress_percent + 25));
        if (s.progress_percent >= 100) {
          s.status = uds::RoutineStatus::kSuccess;
          s.verdict = final_verdict;
          s.reason = final_verdict == uds::RoutineVerdict::kRejected ? Reason::kDeltaBeyondTolerance
                                                                     : Reason::kNone;
          s.delta_rotation_deg = 0.123;
          s.delta_translation_m = 0.0045;
        }
      }
    }
  }

  uds::UdsConfig config_;
  std::unique_ptr<uds::UdsServer> server_;
  UdsServerTransport transport_;
  std::atomic<bool> stop_{true};
  std::thread thread_;
};

class UdsTesterVm : public ::testing::Test {
 protected:
  void SetUp() override {
    ASSERT_TRUE(std::filesystem::exists("/sys/class/net/vcan0")) << "not in the test VM?";
    server_ = std::make_unique<ServerThread>(dir_.path().string());
  }

  /// Runs calibd-tester on vcan0 with `args` (P2 1 s: the VM is emulated, not accelerated).
  TesterRun Tester(const std::string& args, const std::string& timing = "--p2-ms 1000") {
    TesterRun run;
    const std::string out = dir_.file("out.txt"), err = dir_.file("err.txt");
    run.code = testing::RunCommand(TesterExe() + " --interface " + kInterface + " " + timing + " " +
                                   args + " >" + out + " 2>" + err);
    run.out = ReadFile(out);
    run.err = ReadFile(err);
    return run;
  }
  std::string Secret() const { return dir_.file("secret"); }

  TempDir dir_;
  std::unique_ptr<ServerThread> server_;
};

#define EXPECT_HAS(text, part) EXPECT_NE((text).find(part), std::string::npos) << (text)

TEST_F(UdsTesterVm, SessionChange) {
  server_->Start();
  TesterRun r = Tester("session extended");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "session extended (P2 50 ms, P2* 5000 ms)\n");
  r = Tester("session default");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "session default (P2 50 ms, P2* 5000 ms)\n");
  server_->Stop();
  EXPECT_EQ(server_->server().session(), uds::Session::kDefault);
}

TEST_F(UdsTesterVm, UnlockWithTheRightSecret) {
  server_->Start();
  const TesterRun r = Tester("--secret " + Secret() + " unlock");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "unlocked\n");
  server_->Stop();
  EXPECT_TRUE(server_->server().security_unlocked());
}

TEST_F(UdsTesterVm, WrongSecretThreeTimesLocksOut) {
  server_->Start();
  const std::string wrong = dir_.file("wrong_secret");
  testing::WriteFileWithMode(wrong, "not-this-vehicles-secret-0123456", 0600);
  for (int attempt = 1; attempt <= 2; ++attempt) {
    const TesterRun r = Tester("unlock --secret " + wrong);
    EXPECT_EQ(r.code, 5) << r.err;
    EXPECT_HAS(r.err, "calibd-tester: 0x27 SecurityAccess refused: 0x35 invalidKey");
    EXPECT_HAS(r.err, "the secret file does not match this vehicle's");
  }
  TesterRun r = Tester("unlock --secret " + wrong);
  EXPECT_EQ(r.code, 5) << r.err;
  EXPECT_HAS(r.err, "0x36 exceededNumberOfAttempts");
  EXPECT_HAS(r.err, "locked out");
  // Even the right secret waits for the delay now.
  r = Tester("unlock --secret " + Secret());
  EXPECT_EQ(r.code, 5) << r.err;
  EXPECT_HAS(r.err, "0x37 requiredTimeDelayNotExpired");
  EXPECT_EQ(r.out, "");
}

TEST_F(UdsTesterVm, CalibrateFollowsToUpdatedThenCommit) {
  server_->Start();
  TesterRun r = Tester("--secret " + Secret() + " calibrate --static --max-duration 60");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out, "status: success\n");
  EXPECT_HAS(r.out, "verdict: updated\n");
  EXPECT_HAS(r.out, "reason: none\n");
  EXPECT_HAS(r.out, "rotation delta: 0.123 deg\n");
  EXPECT_HAS(r.out, "translation delta: 4.5 mm\n");
  EXPECT_HAS(r.err, "progress 100% success");
  // Commit needs security: without the secret the server refuses, and says how to unlock.
  r = Tester("commit");
  EXPECT_EQ(r.code, 5);
  EXPECT_HAS(r.err, "calibd-tester: 0x31 RoutineControl refused: 0x33 securityAccessDenied");
  EXPECT_HAS(r.err, "unlock first: calibd-tester --secret FILE <command>");
  r = Tester("--secret " + Secret() + " commit");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "commit: success\n");
  server_->Stop();
  EXPECT_EQ(server_->backend.starts, 1);
  EXPECT_EQ(server_->backend.commits, 1);
  EXPECT_EQ(server_->backend.last_options.mode, uds::CalibrationMode::kStatic);
  EXPECT_EQ(server_->backend.last_options.max_duration_s, 60);
}

TEST_F(UdsTesterVm, RejectedVerdictExitsThree) {
  server_->final_verdict = uds::RoutineVerdict::kRejected;
  server_->Start();
  const TesterRun r = Tester("--secret " + Secret() + " --quiet calibrate");
  EXPECT_EQ(r.code, 3) << r.err;
  EXPECT_HAS(r.out, "verdict: rejected\n");
  EXPECT_HAS(r.out, "reason: delta_beyond_tolerance\n");
  EXPECT_EQ(r.err, "");  // --quiet: no progress
}

// verify answering `updated`: the stored calibration is out of tolerance. A station script must
// not read it as a pass, and verify's result cannot be committed: exit 8 and the next step.
TEST_F(UdsTesterVm, VerifyOutOfToleranceIsNoPass) {
  server_->final_verdict = uds::RoutineVerdict::kUpdated;
  server_->Start();
  TesterRun r = Tester("--secret " + Secret() + " --quiet verify");
  EXPECT_EQ(r.code, 8) << r.err;
  EXPECT_HAS(r.out, "verdict: updated\n");
  EXPECT_HAS(r.out, "out of tolerance");
  EXPECT_HAS(r.out, "calibrate, then commit");
  EXPECT_EQ(r.out.find("commit it with"), std::string::npos) << r.out;
  r = Tester("results verify");
  EXPECT_EQ(r.code, 8) << r.err;
  EXPECT_HAS(r.out, "out of tolerance");
  server_->Stop();
  EXPECT_TRUE(server_->backend.last_options.verify_only);
}

TEST_F(UdsTesterVm, StartWithoutWaitingThenStop) {
  server_->step_us = 60 * kSecondUs;  // stays active until stopped
  server_->Start();
  TesterRun r = Tester("--secret " + Secret() + " calibrate --no-wait");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "calibrate started (follow it with: calibd-tester results)\n");
  r = Tester("results");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out, "status: active\n");
  r = Tester("--secret " + Secret() + " stop");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "stopped\n");
  r = Tester("results");
  EXPECT_EQ(r.code, 4) << r.err;
  EXPECT_HAS(r.out, "status: aborted\n");
  EXPECT_HAS(r.out, "reason: stopped\n");
  server_->Stop();
  EXPECT_EQ(server_->backend.stops, 1);
}

TEST_F(UdsTesterVm, VerifyRestoreReferenceAndWriteVin) {
  server_->final_verdict = uds::RoutineVerdict::kVerified;
  server_->Start();
  TesterRun r = Tester("--secret " + Secret() + " --quiet verify");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out, "verdict: verified\n");
  EXPECT_EQ(r.out.find("commit it with"), std::string::npos) << r.out;
  r = Tester("--secret " + Secret() + " restore-reference");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "restore-reference: success\n");
  r = Tester("--secret " + Secret() + " store-reference");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "store-reference: success\n");
  r = Tester("store-reference");  // locked: refused, and nothing stored
  EXPECT_NE(r.code, 0);
  EXPECT_HAS(r.err, "0x33");
  r = Tester("--secret " + Secret() + " write-vin WVWZZZ1KZAW000002");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "VIN written: WVWZZZ1KZAW000002\n");
  server_->Stop();
  EXPECT_TRUE(server_->backend.last_options.verify_only);
  EXPECT_EQ(server_->backend.restores, 1);
  EXPECT_EQ(server_->backend.references_stored, 1);
  EXPECT_EQ(server_->backend.written_vin, "WVWZZZ1KZAW000002");
}

TEST_F(UdsTesterVm, ResultsBeforeAnyStart) {
  server_->Start();
  const TesterRun r = Tester("results");
  EXPECT_EQ(r.code, 5);
  EXPECT_HAS(r.err, "calibd-tester: 0x31 RoutineControl refused: 0x24 requestSequenceError");
  EXPECT_HAS(r.err, "start a calibration first");
}

TEST_F(UdsTesterVm, ReadDidsDecoded) {
  uds::ExtrinsicFigures& e = server_->backend.current;
  e.available = true;
  e.x_m = 0.12345;
  e.y_m = -0.05;
  e.z_m = 0.2;
  e.roll_deg = 90.5;
  e.pitch_deg = -0.25;
  e.yaw_deg = 1.000001;
  server_->Start();
  const TesterRun r = Tester("read FD00,F190,FD03,FD01");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out,
            "FD00 current T_camera_lidar: x 123.45 mm, y -50.00 mm, z 200.00 mm, roll 90.500000 "
            "deg, pitch -0.250000 deg, yaw 1.000001 deg\n"
            "F190 VIN: WVWZZZ1KZAW000001\n"
            "FD03 LiDAR serial number: OT128-0042\n"
            "FD01 reference T_camera_lidar: not available\n");
  const TesterRun bad = Tester("read 1234");
  EXPECT_EQ(bad.code, 5);
  EXPECT_HAS(bad.err, "0x22 ReadDataByIdentifier refused: 0x31 requestOutOfRange");
}

TEST_F(UdsTesterVm, DtcReadAndClear) {
  server_->report_lidar_timeout = true;
  server_->Start();
  TesterRun r = Tester("dtc");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out,
             "C1A01-87 (0x5A0187) LiDAR data timeout: status 0x2F (testFailed, "
             "testFailedThisOperationCycle, pendingDTC, confirmedDTC, testFailedSinceLastClear)\n");
  EXPECT_HAS(r.out, "U0001-88 (0xC00188) CAN bus-off: status");
  r = Tester("dtc --clear");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "DTCs cleared\n");
  r = Tester("dtc");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_HAS(r.out,
             "C1A01-87 (0x5A0187) LiDAR data timeout: status 0x50 (testNotCompletedSinceLastClear, "
             "testNotCompletedThisOperationCycle)\n");
  EXPECT_EQ(r.out.find("testFailed,"), std::string::npos) << r.out;
}

TEST_F(UdsTesterVm, FunctionalTesterPresent) {
  server_->Start();
  TesterRun r = Tester("tester-present --functional");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "TesterPresent answered (7E 00)\n");
  r = Tester("raw 3E 00");
  EXPECT_EQ(r.code, 0) << r.err;
  EXPECT_EQ(r.out, "7E 00\n");
}

TEST_F(UdsTesterVm, NoServerTimesOut) {
  // No server on the bus: the single frame goes out (vcan needs no acknowledgement), no answer.
  const TesterRun r = Tester("read F190", "--p2-ms 300");
  EXPECT_EQ(r.code, 6) << r.err;
  EXPECT_HAS(r.err,
             "calibd-tester: no response to 0x22 ReadDataByIdentifier on vcan0 (0x7E0 -> 0x7E8) "
             "within 3");
  EXPECT_HAS(r.err, "(P2 300 ms)");
}

TEST_F(UdsTesterVm, MissingInterfaceIsNamed) {
  const TesterRun r = Tester("--interface vcan9 read F190");
  EXPECT_EQ(r.code, 7) << r.err;
  EXPECT_HAS(r.err, "calibd-tester: interface vcan9 is not usable");
}

// The client library alone: a hand-made ECU answers 0x78 responsePending twice before the
// positive response, 400 ms after the request in all; P2 (200 ms) alone would have timed out.
TEST_F(UdsTesterVm, ResponsePendingExtendsToP2Star) {
  UdsServerTransport ecu;
  IsoTpConfig isotp;
  isotp.interface = kInterface;
  std::string error;
  ASSERT_TRUE(ecu.Start(isotp, tester::MonotonicUs(), &error)) << error;
  std::atomic<bool> stop{false};
  std::thread thread([&] {
    while (!stop) {
      pollfd fd{ecu.physical_fd(), POLLIN, 0};
      if (::poll(&fd, 1, 10) <= 0) continue;
      IsoTpMessage m;
      if (ecu.Receive(&m) != IsoTpIo::kOk) continue;
      const uint8_t pending[3] = {0x7F, m.data[0], 0x78};
      for (int i = 0; i < 2; ++i) {
        ::usleep(150000);
        ecu.Send(pending, 3);
      }
      ::usleep(100000);
      const uint8_t positive[3] = {0x71, 0x01, 0xF0};
      ecu.Send(positive, 3);
    }
  });
  tester::UdsClient client;
  tester::ClientTiming timing;
  timing.p2_ms = 200;
  timing.p2_star_ms = 1000;
  ASSERT_TRUE(client.Open(isotp, timing, &error)) << error;
  const tester::UdsReply reply = client.Request({0x31, 0x01, 0xF0});
  stop = true;
  thread.join();
  EXPECT_EQ(reply.outcome, tester::UdsReply::Outcome::kPositive);
  EXPECT_EQ(reply.pending_count, 2);
  EXPECT_GE(reply.waited_ms, 350);
  EXPECT_EQ(reply.bytes, (std::vector<uint8_t>{0x71, 0x01, 0xF0}));
}

}  // namespace
}  // namespace calibd
