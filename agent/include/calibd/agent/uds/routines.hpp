#pragma once
/// \file
/// The calibration routines of RoutineControl 0x31 (ISO 14229-1 §13.2): identifiers, option
/// records and result records, all big-endian.
///
/// Identifiers lie in 0xF000-0xFEFF, the systemSupplierSpecific range of ISO 14229-1 Annex F.1
/// (Table F.1; 0x0200-0xDFFF is vehicle-manufacturer-specific, 0xE000-0xE1FF OBD, 0xFF00
/// eraseMemory, 0xFF01 checkProgrammingDependencies).
///
/// - 0xF0A0 calibrate: start with the option record below; stop; results = the record below
/// - 0xF0A1 commit the last `updated` result to the store: start (no option record); results =
///   the status of the last start; no stop (0x12)
/// - 0xF0A2 restore the factory / end-of-line reference: as commit
/// - 0xF0A3 verify: as calibrate, but the result is only compared with the stored calibration
///   and never committed
/// - 0xF0A4 store the current calibration as the reference (the end-of-line line's provisioning,
///   what 0xF0A2 later restores): as commit
///
/// Calibrate option record (3 bytes): byte 0 CalibrationMode (0x00 moving: the vehicle drives
/// past the boards; 0x01 static: the vehicle is parked and the boards are moved), bytes 1-2 the
/// collection time limit in s (0: the agent's configured limit; at most 3600, else 0x31).
/// Verify takes the same record: a session whose result is compared with the stored calibration
/// and never committed.
///
/// Every positive response carries, after the RID, one byte RoutineStatus (routineInfo).
/// requestRoutineResults (0x03) of calibrate/verify returns kCalibrationResultSize bytes after the
/// RID:
///   byte 0    RoutineStatus
///   byte 1    progress, % (0-100): below 90 while collecting, 90 while solving, 100 done
///   byte 2    RoutineVerdict
///   byte 3    Reason (core reason.hpp: why it failed, aborted or was rejected; 0 otherwise)
///   bytes 4-5 rotation change vs the prior calibration, u16 in 0.001 deg (saturates at 65.535)
///   bytes 6-7 translation change vs the prior, u16 in 0.1 mm (saturates at 6.5535 m)
/// For commit, restore and store-reference the result is the status byte of the last start
/// (success or failed).

#include <cstdint>
#include <string_view>

#include "calibd/core/verdict/reason.hpp"

namespace calibd::uds {

enum RoutineId : uint16_t {
  kRoutineCalibrate = 0xF0A0,
  kRoutineCommit = 0xF0A1,
  kRoutineRestoreReference = 0xF0A2,
  kRoutineVerify = 0xF0A3,
  kRoutineStoreReference = 0xF0A4,
};

/// routineControlType (ISO 14229-1 §13.2.2.2 Table 376).
enum RoutineControlType : uint8_t {
  kStartRoutine = 0x01,
  kStopRoutine = 0x02,
  kRequestRoutineResults = 0x03,
};

enum class CalibrationMode : uint8_t { kMoving = 0x00, kStatic = 0x01 };

/// Start option record of calibrate / verify, decoded.
struct CalibrateOptions {
  CalibrationMode mode = CalibrationMode::kMoving;
  uint16_t max_duration_s = 0;  ///< 0: the agent's configured limit
  bool verify_only = false;     ///< started as 0xF0A3 verify
};
inline constexpr int kCalibrateOptionSize = 3;
inline constexpr uint16_t kMaxCalibrationDurationS = 3600;  ///< = kMaxSessionDurationUs

enum class RoutineStatus : uint8_t {
  kIdle = 0x00,     ///< never started since the agent started
  kActive = 0x01,   ///< collecting or solving
  kSuccess = 0x02,  ///< finished with a verdict (see RoutineVerdict), or commit/restore done
  kAborted = 0x03,  ///< stopped by the tester, S3 timeout or a session change
  kFailed = 0x04,   ///< could not reach a verdict (see Reason), or commit/restore failed
};

enum class RoutineVerdict : uint8_t {
  kNone = 0x00,      ///< no verdict (yet)
  kVerified = 0x01,  ///< the stored calibration still holds
  kUpdated = 0x02,   ///< a new calibration is ready (commit with 0xF0A1)
  kRejected = 0x03,  ///< the new estimate is not trusted (see Reason)
};

/// The results record's reason byte is calibd::Reason's code (core reason.hpp: one table of codes
/// and names for the engine, the session machine, the logs and this record).

/// What the owner reports for calibrate / verify (UdsBackend::CalibrationStatus).
struct RoutineSnapshot {
  RoutineStatus status = RoutineStatus::kIdle;
  uint8_t progress_percent = 0;
  RoutineVerdict verdict = RoutineVerdict::kNone;
  Reason reason = Reason::kNone;
  double delta_rotation_deg = 0.0;  ///< change vs the prior calibration
  double delta_translation_m = 0.0;
};
inline constexpr int kCalibrationResultSize = 8;

}  // namespace calibd::uds
