#pragma once
/// \file
/// What the UDS server asks of its owner (the agent, over SessionMachine and CalibrationStore):
/// the server decides the protocol (sessions, security, NRCs), the owner acts and reports. Every
/// call is made from UdsServer::Handle or Tick, on the owner's thread, and must not block.

#include <cstdint>
#include <string_view>

#include "calibd/agent/uds/did_codec.hpp"
#include "calibd/agent/uds/routines.hpp"

namespace calibd::uds {

/// The owner's answer to an action; the server turns a refusal into its NRC.
enum class BackendReply : uint8_t {
  kAccepted,
  kConditionsNotCorrect,  ///< -> 0x22 (e.g. a session already running)
  kSequenceError,         ///< -> 0x24 (e.g. commit with nothing to commit, stop when idle)
  kOutOfRange,            ///< -> 0x31 (e.g. an option the owner cannot honour)
  kFailure,               ///< -> 0x72 generalProgrammingFailure (e.g. the store write failed)
};

/// Preconditions of starting a routine (0x22 when one is false).
struct RoutineConditions {
  bool interlock_asserted = false;  ///< the interlock GPIO (true when none is configured)
  bool lidar_alive = false;         ///< LiDAR frames arrived recently
  bool camera_alive = false;
};

class UdsBackend {
 public:
  virtual ~UdsBackend() = default;

  virtual RoutineConditions Conditions() const = 0;
  /// calibrate (verify_only false) or verify (true): starts a session and returns at once.
  virtual BackendReply StartCalibration(const CalibrateOptions& options) = 0;
  /// stopRoutine of calibrate/verify.
  virtual BackendReply StopCalibration() = 0;
  /// The extended session in which the server started calibrate/verify ended (S3 timeout, change
  /// to the default session): abort that session if it is still running, reporting
  /// Reason::kSessionEnded. No reply.
  virtual void AbortCalibration() = 0;
  virtual RoutineSnapshot CalibrationStatus() const = 0;
  /// Commit the last `updated` result to the store.
  virtual BackendReply Commit() = 0;
  /// Make the factory / end-of-line reference the current calibration.
  virtual BackendReply RestoreReference() = 0;
  /// Keep the current calibration as the reference (what RestoreReference brings back).
  virtual BackendReply StoreReference() = 0;

  // --- data identifiers (did_codec.hpp). Views must stay valid until the call returns. ---
  virtual std::string_view Vin() const = 0;
  virtual bool WriteVin(std::string_view vin) = 0;  ///< false: not stored (-> 0x72)
  virtual std::string_view SoftwareVersion() const = 0;
  virtual int64_t CalibrationUnixS() const = 0;  ///< created_unix_s of the current; 0: none
  virtual ExtrinsicFigures CurrentExtrinsic() const = 0;
  virtual ExtrinsicFigures ReferenceExtrinsic() const = 0;
  virtual QualityFigures Quality() const = 0;
  virtual std::string_view LidarSerial() const = 0;
  virtual std::string_view CameraSerial() const = 0;
  virtual CalibrationState State() const = 0;
  /// The running (or last) session's coverage against its gates (DID 0xFD06).
  virtual CaptureCoverage Coverage() const = 0;

  /// 0x11 hardReset was accepted: restart once the positive response has been sent.
  virtual void ResetRequested() = 0;
};

}  // namespace calibd::uds
