#pragma once
/// \file
/// The server's diagnostic trouble codes with their ISO 14229-1 Annex D.2 status bits, kept in a
/// file of the state directory (replaced atomically on every change).
///
/// DTC numbers in the SAE J2012 format (DTCFormatIdentifier 0x00): two bytes of code, one byte of
/// failure type (J2012-DA FTB). C1A0x are supplier-defined chassis codes; U0001 is J2012's
/// "high speed CAN communication bus".
///
/// - C1A00-54 = 0x5A0054: calibration not performed (FTB 54 missing calibration)
/// - C1A00-64 = 0x5A0064: calibration result rejected (FTB 64 signal plausibility failure)
/// - C1A00-56 = 0x5A0056: recalibration required, a sensor was replaced (FTB 56
///   invalid/incompatible configuration)
/// - C1A01-87 = 0x5A0187: LiDAR data timeout (FTB 87 missing message)
/// - C1A02-87 = 0x5A0287: camera data timeout (FTB 87 missing message)
/// - C1A00-46 = 0x5A0046: calibration store corrupt (FTB 46 calibration/parameter memory failure)
/// - U0001-88 = 0xC00188: CAN bus-off (FTB 88 bus off)
/// - C1A00-44 = 0x5A0044: calibration store write failed (FTB 44 data memory failure): the last
///   commit, restore or verification could not be written (full or read-only filesystem, I/O
///   error); the previous calibration stays in use. Passes at the next successful store write.
/// - C1A03-00 = 0x5A0300: calibration session interrupted (C1A03 the calibration routine, FTB 00
///   no sub-type information): the previous run of the agent stopped during a session without a
///   result (killed, crashed, power lost), found at start-up from the session marker the run
///   left in the store directory; the stored calibration is unchanged. Passes when a session
///   next ends with a result.
///
/// Status bits (Annex D.2): bit 0 testFailed, 1 testFailedThisOperationCycle, 2 pendingDTC,
/// 3 confirmedDTC, 4 testNotCompletedSinceLastClear, 5 testFailedSinceLastClear,
/// 6 testNotCompletedThisOperationCycle; bit 7 warningIndicatorRequested is not supported
/// (availability mask 0x7F). Rules: a failed test sets 0, 1, 2, 3 (confirmed at the first
/// failure: a one-trip DTC) and 5; a passed test clears 0; any test result clears 4 and 6. A new
/// operation cycle (agent start) clears 1, sets 6, and clears 2 when the previous cycle completed
/// the test without failing. Clear (0x14) sets every status to 0x50. While DTC setting is off
/// (0x85 02) test results change nothing.
///
/// File `<state_dir>/dtc_status`: "calibd-dtc 1" then one line "<dtc hex6> <status hex2>" per
/// DTC, then "end". A missing file is a fresh store; a corrupt one too, reported in warning(). A
/// DTC without a line (a file written before that DTC existed) starts cleared.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

namespace calibd::uds {

enum class Dtc : uint8_t {
  kCalibrationNotPerformed,
  kResultRejected,
  kRecalibrationRequired,
  kLidarTimeout,
  kCameraTimeout,
  kStoreCorrupt,
  kCanBusOff,
  kStoreWriteFailed,
  kSessionInterrupted,
};
inline constexpr size_t kDtcCount = 9;
/// The three-byte DTC number of each Dtc, in enum order.
inline constexpr std::array<uint32_t, kDtcCount> kDtcNumbers = {
    0x5A0054, 0x5A0064, 0x5A0056, 0x5A0187, 0x5A0287, 0x5A0046, 0xC00188, 0x5A0044, 0x5A0300};

enum DtcStatusBit : uint8_t {
  kTestFailed = 0x01,
  kTestFailedThisOperationCycle = 0x02,
  kPendingDtc = 0x04,
  kConfirmedDtc = 0x08,
  kTestNotCompletedSinceLastClear = 0x10,
  kTestFailedSinceLastClear = 0x20,
  kTestNotCompletedThisOperationCycle = 0x40,
};
inline constexpr uint8_t kDtcStatusAvailabilityMask = 0x7F;
inline constexpr uint8_t kDtcStatusAfterClear = 0x50;
inline constexpr uint8_t kDtcFormatJ2012 = 0x00;  ///< DTCFormatIdentifier (§11.3.2.2 Table 271)

class DtcStore {
 public:
  /// Loads `<state_dir>/dtc_status`; a missing or corrupt file leaves every DTC cleared (a
  /// corrupt one is reported in warning()). Then starts a new operation cycle.
  void Open(const std::string& state_dir);

  /// A test result. Ignored while setting is disabled. Persists on a change; false with `error`
  /// when the file could not be written (the status in memory is kept).
  bool Report(Dtc dtc, bool failed, std::string* error);
  /// 0x14 with group 0xFFFFFF: every DTC back to kDtcStatusAfterClear, persisted.
  bool ClearAll(std::string* error);
  /// 0x85: DTC setting on (true) / off (false).
  void SetEnabled(bool enabled) { enabled_ = enabled; }
  bool enabled() const { return enabled_; }

  uint8_t status(size_t index) const { return status_[index]; }
  uint8_t status(Dtc dtc) const { return status_[static_cast<size_t>(dtc)]; }
  /// Index of a DTC number; -1 when not one of ours.
  static int IndexOf(uint32_t number);
  /// What Open found wrong with the file; empty otherwise.
  const std::string& warning() const { return warning_; }

 private:
  void NewOperationCycle();
  bool Save(std::string* error) const;

  std::string path_;
  std::array<uint8_t, kDtcCount> status_{};
  bool enabled_ = true;
  std::string warning_;
};

}  // namespace calibd::uds
