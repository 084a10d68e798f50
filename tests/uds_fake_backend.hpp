#pragma once
// A UdsBackend for the UDS server's tests: records what the server asked for and answers from
// fields the test sets. Allocates nothing in its calls (strings are set up front).

#include <sys/stat.h>

#include <cstdint>
#include <fstream>
#include <string>
#include <string_view>
#include <vector>

#include "calibd/agent/uds/uds_backend.hpp"
#include "calibd/agent/uds/uds_config.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "temp_dir.hpp"

namespace calibd::testing {

class FakeUdsBackend : public uds::UdsBackend {
 public:
  uds::RoutineConditions conditions{true, true, true};
  uds::RoutineSnapshot snapshot;
  uds::BackendReply start_reply = uds::BackendReply::kAccepted;
  uds::BackendReply commit_reply = uds::BackendReply::kAccepted;
  uds::BackendReply restore_reply = uds::BackendReply::kAccepted;
  uds::BackendReply store_reference_reply = uds::BackendReply::kAccepted;
  bool write_vin_ok = true;
  std::string vin = "WVWZZZ1KZAW000001";
  std::string software_version = "0.6.0";
  std::string lidar_serial = "OT128-0042";
  std::string camera_serial = "CAM-7";
  int64_t calibration_unix_s = 0;
  uds::ExtrinsicFigures current, reference;
  uds::QualityFigures quality;
  uds::CalibrationState state = uds::CalibrationState::kNotPerformed;
  CaptureCoverage coverage;

  // What the server did.
  int starts = 0, stops = 0, aborts = 0, commits = 0, restores = 0, references_stored = 0,
      resets = 0;
  uds::CalibrateOptions last_options;
  std::string written_vin;

  uds::RoutineConditions Conditions() const override { return conditions; }
  uds::BackendReply StartCalibration(const uds::CalibrateOptions& options) override {
    if (start_reply != uds::BackendReply::kAccepted) return start_reply;
    ++starts;
    last_options = options;
    snapshot = {};
    snapshot.status = uds::RoutineStatus::kActive;
    return start_reply;
  }
  uds::BackendReply StopCalibration() override {
    ++stops;
    snapshot.status = uds::RoutineStatus::kAborted;
    snapshot.reason = Reason::kStopped;
    return uds::BackendReply::kAccepted;
  }
  void AbortCalibration() override {
    ++aborts;
    if (snapshot.status == uds::RoutineStatus::kActive) {
      snapshot.status = uds::RoutineStatus::kAborted;
      snapshot.reason = Reason::kSessionEnded;
    }
  }
  uds::RoutineSnapshot CalibrationStatus() const override { return snapshot; }
  uds::BackendReply Commit() override {
    ++commits;
    return commit_reply;
  }
  uds::BackendReply RestoreReference() override {
    ++restores;
    return restore_reply;
  }
  uds::BackendReply StoreReference() override {
    ++references_stored;
    return store_reference_reply;
  }
  std::string_view Vin() const override { return vin; }
  bool WriteVin(std::string_view v) override {
    if (!write_vin_ok) return false;
    written_vin.assign(v.data(), v.size());
    return true;
  }
  std::string_view SoftwareVersion() const override { return software_version; }
  int64_t CalibrationUnixS() const override { return calibration_unix_s; }
  uds::ExtrinsicFigures CurrentExtrinsic() const override { return current; }
  uds::ExtrinsicFigures ReferenceExtrinsic() const override { return reference; }
  uds::QualityFigures Quality() const override { return quality; }
  std::string_view LidarSerial() const override { return lidar_serial; }
  std::string_view CameraSerial() const override { return camera_serial; }
  uds::CalibrationState State() const override { return state; }
  CaptureCoverage Coverage() const override { return coverage; }
  void ResetRequested() override { ++resets; }
};

inline constexpr char kTestSecret[] = "calibd-test-secret-0123456789abc";  // 32 bytes

/// Writes `contents` to `path` with `mode`.
inline void WriteFileWithMode(const std::string& path, const std::string& contents, mode_t mode) {
  std::ofstream(path, std::ios::binary) << contents;
  ::chmod(path.c_str(), mode);
}

/// A config over `dir`: secret file (mode 0600) and state dir inside it.
inline uds::UdsConfig TestUdsConfig(const std::string& dir) {
  uds::UdsConfig c;
  c.secret_file = dir + "/secret";
  c.state_dir = dir;
  c.ecu_serial = "ECU-0001";
  WriteFileWithMode(c.secret_file, kTestSecret, 0600);
  return c;
}

/// Sends `request`; the response bytes (empty: none).
inline std::vector<uint8_t> Send(uds::UdsServer& server, const std::vector<uint8_t>& request,
                                 int64_t now_us, bool functional = false) {
  const uds::Response r = server.Handle(request.data(), request.size(), functional, now_us);
  return std::vector<uint8_t>(r.data, r.data + r.size);
}

/// What every UDS test file uses: `using namespace calibd::testing::uds_test;`.
namespace uds_test {
using calibd::testing::FakeUdsBackend;
using calibd::testing::Send;
using calibd::testing::TempDir;
using Bytes = std::vector<uint8_t>;
inline constexpr int64_t kS = 1000 * 1000;
inline constexpr int64_t kT0 = 100 * kS;                      ///< monotonic time of the tests
inline constexpr int64_t kUnix0 = 1'700'000'000LL * 1000000;  ///< wall clock at kT0
}  // namespace uds_test

}  // namespace calibd::testing
