#include "calibd/agent/uds/uds_server.hpp"

#include <cstring>

namespace calibd::uds {
namespace {

uint16_t U16(const uint8_t* p) { return static_cast<uint16_t>(p[0] << 8 | p[1]); }
uint32_t U24(const uint8_t* p) {
  return static_cast<uint32_t>(p[0]) << 16 | static_cast<uint32_t>(p[1]) << 8 | p[2];
}

/// ISO 14229-1 §7.5.2: NRCs a server does not send to a functionally addressed request.
bool SuppressedWhenFunctional(Nrc nrc) {
  return nrc == kNrcServiceNotSupported || nrc == kNrcSubFunctionNotSupported ||
         nrc == kNrcRequestOutOfRange || nrc == kNrcSubFunctionNotSupportedInActiveSession ||
         nrc == kNrcServiceNotSupportedInActiveSession;
}

Nrc FromBackend(BackendReply reply) {
  switch (reply) {
    case BackendReply::kAccepted:
      return kNrcNone;
    case BackendReply::kConditionsNotCorrect:
      return kNrcConditionsNotCorrect;
    case BackendReply::kSequenceError:
      return kNrcRequestSequenceError;
    case BackendReply::kOutOfRange:
      return kNrcRequestOutOfRange;
    case BackendReply::kFailure:
      break;
  }
  return kNrcGeneralProgrammingFailure;
}

/// VIN characters (ISO 3779): digits and capitals without I, O, Q.
bool IsVinChar(uint8_t c) {
  return (c >= '0' && c <= '9') || (c >= 'A' && c <= 'Z' && c != 'I' && c != 'O' && c != 'Q');
}

}  // namespace

bool MayWriteStorage(const uint8_t* request, size_t size) {
  if (size == 0) return false;
  const uint8_t sub = size >= 2 ? request[1] & ~kSuppressPosRspBit : 0;
  switch (request[0]) {
    case kSidRoutineControl:
      return sub == 0x01 || sub == 0x02;  // start, stop (not requestRoutineResults)
    case kSidSecurityAccess:
      return size >= 2 && sub % 2 == 0;  // sendKey (even levels)
    case kSidWriteDataByIdentifier:
    case kSidClearDiagnosticInformation:
      return true;
    default:
      return false;
  }
}

UdsServer::UdsServer(const UdsConfig& config, UdsBackend* backend)
    : config_(config), backend_(backend) {}

bool UdsServer::Init(int64_t now_us, int64_t now_unix_us, std::string* error) {
  if (!security_.Init(config_, now_us, now_unix_us, error)) return false;
  dtcs_.Open(config_.state_dir);
  session_ = Session::kDefault;
  last_request_us_ = now_us;
  return true;
}

std::string UdsServer::warnings() const {
  std::string out = security_.warning();
  if (!dtcs_.warning().empty()) out += (out.empty() ? "" : "; ") + dtcs_.warning();
  return out;
}

void UdsServer::EnterDefaultSession() {
  session_ = Session::kDefault;
  security_.Lock();
  dtcs_.SetEnabled(true);  // §9.9.1: DTC setting off ends with the non-default session
  // Only a routine this server started: a session started by a start button or over LCM is not
  // the tester's to end.
  if (routine_started_in_session_) backend_->AbortCalibration();
  routine_started_in_session_ = false;
}

void UdsServer::Tick(int64_t now_us) {
  // ISO 14229-2 §9.3: S3server runs in every non-default session.
  if (session_ != Session::kDefault && now_us - last_request_us_ >= config_.s3_us) {
    EnterDefaultSession();
  }
}

Response UdsServer::Handle(const uint8_t* request, size_t size, bool functional, int64_t now_us,
                           bool pending_sent) {
  if (size == 0) return {};
  Tick(now_us);  // an expired S3 takes effect before this request
  last_request_us_ = now_us;
  nrc_ = kNrcNone;
  suppress_positive_ = false;
  const size_t n = Dispatch(request, size, now_us);
  if (nrc_ != kNrcNone) {
    if (functional && SuppressedWhenFunctional(nrc_)) return {};
    buffer_[0] = kSidNegativeResponse;
    buffer_[1] = request[0];
    buffer_[2] = nrc_;
    return {buffer_.data(), 3};
  }
  if ((suppress_positive_ && !pending_sent) || n == 0) return {};
  return {buffer_.data(), n};
}

size_t UdsServer::Dispatch(const uint8_t* req, size_t size, int64_t now_us) {
  const bool extended = session_ == Session::kExtended;
  // ISO 14229-1 §7.5.1 Figure 5: service supported (0x11), then in this session (0x7F).
  switch (req[0]) {
    case kSidDiagnosticSessionControl:
      return SessionControl(req, size);
    case kSidEcuReset:
      return EcuReset(req, size);
    case kSidClearDiagnosticInformation:
      return ClearDtc(req, size);
    case kSidReadDtcInformation:
      return ReadDtc(req, size);
    case kSidReadDataByIdentifier:
      return ReadData(req, size);
    case kSidTesterPresent:
      return TesterPresent(req, size);
    case kSidSecurityAccess:
      return extended ? SecurityAccessService(req, size, now_us)
                      : Fail(kNrcServiceNotSupportedInActiveSession);
    case kSidWriteDataByIdentifier:
      return extended ? WriteData(req, size) : Fail(kNrcServiceNotSupportedInActiveSession);
    case kSidRoutineControl:
      return extended ? RoutineControl(req, size) : Fail(kNrcServiceNotSupportedInActiveSession);
    case kSidControlDtcSetting:
      return extended ? ControlDtcSetting(req, size) : Fail(kNrcServiceNotSupportedInActiveSession);
    default:
      return Fail(kNrcServiceNotSupported);
  }
}

// ISO 14229-1 §9.2 DiagnosticSessionControl.
size_t UdsServer::SessionControl(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  if (type != static_cast<uint8_t>(Session::kDefault) &&
      type != static_cast<uint8_t>(Session::kExtended)) {
    return Fail(kNrcSubFunctionNotSupported);  // 0x02 programming too: no flash loader
  }
  if (size != 2) return Fail(kNrcIncorrectMessageLength);
  // §9.2.1: leaving a non-default session (even for the same one) locks security.
  if (session_ != Session::kDefault) security_.Lock();
  if (type == static_cast<uint8_t>(Session::kDefault)) {
    EnterDefaultSession();
  } else {
    session_ = Session::kExtended;
  }
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  // §9.2.3 Table 30: sessionParameterRecord = P2server_max (1 ms), P2*server_max (10 ms).
  buffer_[0] = kSidDiagnosticSessionControl + kPositiveResponseOffset;
  buffer_[1] = type;
  PutU16(&buffer_[2], static_cast<uint16_t>(config_.p2_ms));
  PutU16(&buffer_[4], static_cast<uint16_t>(config_.p2_star_ms / 10));
  return 6;
}

// ISO 14229-1 §9.3 ECUReset: the owner restarts the agent after sending the response.
size_t UdsServer::EcuReset(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  if (type != 0x01) return Fail(kNrcSubFunctionNotSupported);  // hardReset only
  if (size != 2) return Fail(kNrcIncorrectMessageLength);
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  backend_->ResetRequested();
  buffer_[0] = kSidEcuReset + kPositiveResponseOffset;
  buffer_[1] = type;
  return 2;
}

// ISO 14229-1 §11.2 ClearDiagnosticInformation (no sub-function).
size_t UdsServer::ClearDtc(const uint8_t* req, size_t size) {
  if (size != 4) return Fail(kNrcIncorrectMessageLength);
  const uint32_t group = U24(&req[1]);
  std::string error;
  if (group == 0xFFFFFF) {
    if (!dtcs_.ClearAll(&error)) return Fail(kNrcGeneralProgrammingFailure);
  } else {
    return Fail(kNrcRequestOutOfRange);  // only the "all groups" group is defined
  }
  buffer_[0] = kSidClearDiagnosticInformation + kPositiveResponseOffset;
  return 1;
}

// ISO 14229-1 §11.3 ReadDTCInformation.
size_t UdsServer::ReadDtc(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  size_t expected = 0;
  switch (type) {
    case 0x01:  // reportNumberOfDTCByStatusMask: DTCStatusMask
    case 0x02:  // reportDTCByStatusMask: DTCStatusMask
      expected = 3;
      break;
    case 0x04:  // reportDTCSnapshotRecordByDTCNumber: DTC, record number
    case 0x06:  // reportDTCExtDataRecordByDTCNumber: DTC, record number
      expected = 6;
      break;
    case 0x0A:  // reportSupportedDTC
      expected = 2;
      break;
    default:
      return Fail(kNrcSubFunctionNotSupported);
  }
  if (size != expected) return Fail(kNrcIncorrectMessageLength);
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  buffer_[0] = kSidReadDtcInformation + kPositiveResponseOffset;
  buffer_[1] = type;
  size_t n = 2;
  if (type == 0x04 || type == 0x06) {
    const int index = DtcStore::IndexOf(U24(&req[2]));
    const uint8_t record = req[5];
    // Record 0x01 and "all" (0xFF) are known; none holds data (see below).
    if (index < 0 || (record != 0x01 && record != 0xFF)) return Fail(kNrcRequestOutOfRange);
    // §11.3.5.4 / §11.3.5.6: DTCAndStatusRecord followed by the stored records. This server
    // keeps no snapshot or extended data, so the minimal record is DTC + status, no records.
    n += 3;
    buffer_[2] = req[2];
    buffer_[3] = req[3];
    buffer_[4] = req[4];
    buffer_[n++] = dtcs_.status(static_cast<size_t>(index));
    return n;
  }
  const uint8_t mask = type == 0x0A ? 0xFF : static_cast<uint8_t>(req[2]);
  buffer_[n++] = kDtcStatusAvailabilityMask;
  if (type == 0x01) {
    uint16_t count = 0;
    for (size_t i = 0; i < kDtcCount; ++i) {
      if ((dtcs_.status(i) & mask & kDtcStatusAvailabilityMask) != 0) ++count;
    }
    buffer_[n++] = kDtcFormatJ2012;
    n += PutU16(&buffer_[n], count);
    return n;
  }
  for (size_t i = 0; i < kDtcCount; ++i) {
    const uint8_t status = dtcs_.status(i);
    // 0x0A reports every supported DTC whatever its status; 0x02 those matching the mask.
    if (type == 0x02 && (status & mask & kDtcStatusAvailabilityMask) == 0) continue;
    buffer_[n++] = static_cast<uint8_t>(kDtcNumbers[i] >> 16);
    buffer_[n++] = static_cast<uint8_t>(kDtcNumbers[i] >> 8);
    buffer_[n++] = static_cast<uint8_t>(kDtcNumbers[i]);
    buffer_[n++] = status;
  }
  return n;
}

size_t UdsServer::ReadOneDid(uint16_t did, uint8_t* out, size_t room) {
  size_t need = 0;
  switch (did) {
    case kDidEcuSerial:
    case kDidSoftwareVersion:
      need = kEcuSerialSize;
      break;
    case kDidVin:
      need = kVinSize;
      break;
    case kDidCalibrationDate:
      need = 4;
      break;
    case kDidCurrentExtrinsic:
    case kDidReferenceExtrinsic:
      need = kExtrinsicSize;
      break;
    case kDidQualityFigures:
      need = kQualitySize;
      break;
    case kDidLidarSerial:
    case kDidCameraSerial:
      need = kSensorSerialSize;
      break;
    case kDidCalibrationState:
      need = 2;
      break;
    case kDidCaptureCoverage:
      need = kCoverageSize;
      break;
    default:
      return 0;
  }
  if (2 + need > room) return SIZE_MAX;
  size_t n = PutU16(out, did);
  uint8_t* data = out + n;
  switch (did) {
    case kDidEcuSerial:
      PutPaddedAscii(data, config_.ecu_serial, kEcuSerialSize);
      break;
    case kDidSoftwareVersion:
      PutPaddedAscii(data, backend_->SoftwareVersion(), kSoftwareVersionSize);
      break;
    case kDidVin:
      PutPaddedAscii(data, backend_->Vin(), kVinSize);
      break;
    case kDidCalibrationDate:
      EncodeBcdDate(backend_->CalibrationUnixS(), data);
      break;
    case kDidCurrentExtrinsic:
      EncodeExtrinsic(backend_->CurrentExtrinsic(), data);
      break;
    case kDidReferenceExtrinsic:
      EncodeExtrinsic(backend_->ReferenceExtrinsic(), data);
      break;
    case kDidQualityFigures:
      EncodeQuality(backend_->Quality(), data);
      break;
    case kDidLidarSerial:
      PutPaddedAscii(data, backend_->LidarSerial(), kSensorSerialSize);
      break;
    case kDidCameraSerial:
      PutPaddedAscii(data, backend_->CameraSerial(), kSensorSerialSize);
      break;
    case kDidCalibrationState:
      data[0] = static_cast<uint8_t>(backend_->State());
      data[1] = static_cast<uint8_t>(backend_->CalibrationStatus().status);
      break;
    case kDidCaptureCoverage:
      EncodeCoverage(backend_->Coverage(), data);
      break;
    default:
      break;
  }
  return n + need;
}

// ISO 14229-1 §10.2 ReadDataByIdentifier: unsupported DIDs of a multi-DID request are left out;
// 0x31 only when none is supported.
size_t UdsServer::ReadData(const uint8_t* req, size_t size) {
  if (size < 3 || (size - 1) % 2 != 0 || (size - 1) / 2 > kMaxDidsPerRead) {
    return Fail(kNrcIncorrectMessageLength);
  }
  buffer_[0] = kSidReadDataByIdentifier + kPositiveResponseOffset;
  size_t n = 1;
  for (size_t i = 1; i + 1 < size; i += 2) {
    const size_t written = ReadOneDid(U16(&req[i]), &buffer_[n], buffer_.size() - n);
    if (written == SIZE_MAX) return Fail(kNrcResponseTooLong);
    n += written;
  }
  if (n == 1) return Fail(kNrcRequestOutOfRange);
  return n;
}

// ISO 14229-1 §9.4 SecurityAccess (extended session only, checked by Dispatch).
size_t UdsServer::SecurityAccessService(const uint8_t* req, size_t size, int64_t now_us) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  if (type != 0x01 && type != 0x02) return Fail(kNrcSubFunctionNotSupported);
  buffer_[0] = kSidSecurityAccess + kPositiveResponseOffset;
  buffer_[1] = type;
  if (type == 0x01) {
    if (size != 2) return Fail(kNrcIncorrectMessageLength);
    const Nrc nrc = security_.RequestSeed(now_us, &buffer_[2]);
    if (nrc != kNrcNone) return Fail(nrc);
    suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
    return 2 + kSeedSize;
  }
  const Nrc nrc = security_.SendKey(&req[2], size - 2, now_us);
  if (nrc != kNrcNone) return Fail(nrc);
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  return 2;
}

// ISO 14229-1 §10.7 WriteDataByIdentifier: VIN only, extended session and unlocked.
size_t UdsServer::WriteData(const uint8_t* req, size_t size) {
  if (size < 4) return Fail(kNrcIncorrectMessageLength);
  const uint16_t did = U16(&req[1]);
  if (did != kDidVin) return Fail(kNrcRequestOutOfRange);
  if (!security_.unlocked()) return Fail(kNrcSecurityAccessDenied);
  if (size != 3 + kVinSize) return Fail(kNrcIncorrectMessageLength);
  for (size_t i = 3; i < size; ++i) {
    if (!IsVinChar(req[i])) return Fail(kNrcRequestOutOfRange);
  }
  if (!backend_->WriteVin(std::string_view(reinterpret_cast<const char*>(&req[3]), kVinSize))) {
    return Fail(kNrcGeneralProgrammingFailure);
  }
  buffer_[0] = kSidWriteDataByIdentifier + kPositiveResponseOffset;
  buffer_[1] = req[1];
  buffer_[2] = req[2];
  return 3;
}

size_t UdsServer::RoutineReply(const uint8_t* req, uint8_t status) {
  buffer_[0] = kSidRoutineControl + kPositiveResponseOffset;
  buffer_[1] = req[1] & ~kSuppressPosRspBit;
  buffer_[2] = req[2];
  buffer_[3] = req[3];
  buffer_[4] = status;
  return 5;
}

// ISO 14229-1 §13.2 RoutineControl (extended session only, checked by Dispatch). Check order:
// sub-function (0x12), routine id (0x31), stop on a routine without stop (0x12), security for
// start/stop (0x33), sequence (0x24), exact length (0x13), option range (0x31), conditions
// (0x22), then the owner's answer.
size_t UdsServer::RoutineControl(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  if (type != kStartRoutine && type != kStopRoutine && type != kRequestRoutineResults) {
    return Fail(kNrcSubFunctionNotSupported);
  }
  if (size < 4) return Fail(kNrcIncorrectMessageLength);
  const uint16_t rid = U16(&req[2]);
  const bool session_routine = rid == kRoutineCalibrate || rid == kRoutineVerify;
  if (!session_routine && rid != kRoutineCommit && rid != kRoutineRestoreReference &&
      rid != kRoutineStoreReference) {
    return Fail(kNrcRequestOutOfRange);
  }
  if (type == kStopRoutine && !session_routine) return Fail(kNrcSubFunctionNotSupported);
  if (type != kRequestRoutineResults && !security_.unlocked()) {
    return Fail(kNrcSecurityAccessDenied);
  }
  const bool suppress = (req[1] & kSuppressPosRspBit) != 0;

  if (type == kRequestRoutineResults) {
    if (session_routine) {
      if (!calibrate_started_) return Fail(kNrcRequestSequenceError);
      if (size != 4) return Fail(kNrcIncorrectMessageLength);
      const RoutineSnapshot s = backend_->CalibrationStatus();
      size_t n = RoutineReply(req, static_cast<uint8_t>(s.status));
      buffer_[n++] = s.progress_percent > 100 ? uint8_t{100} : s.progress_percent;
      buffer_[n++] = static_cast<uint8_t>(s.verdict);
      buffer_[n++] = static_cast<uint8_t>(s.reason);
      n += PutU16(&buffer_[n], ScaleToUint16(s.delta_rotation_deg, kRotationFigureLsbDeg));
      n += PutU16(&buffer_[n], ScaleToUint16(s.delta_translation_m, kLengthFigureLsbM));
      suppress_positive_ = suppress;
      return n;
    }
    const RoutineStatus last = StoreRoutineStatus(rid);
    if (last == RoutineStatus::kIdle) return Fail(kNrcRequestSequenceError);
    if (size != 4) return Fail(kNrcIncorrectMessageLength);
    suppress_positive_ = suppress;
    return RoutineReply(req, static_cast<uint8_t>(last));
  }

  if (type == kStopRoutine) {
    if (backend_->CalibrationStatus().status != RoutineStatus::kActive) {
      return Fail(kNrcRequestSequenceError);
    }
    if (size != 4) return Fail(kNrcIncorrectMessageLength);
    const Nrc nrc = FromBackend(backend_->StopCalibration());
    if (nrc != kNrcNone) return Fail(nrc);
    suppress_positive_ = suppress;
    return RoutineReply(req, static_cast<uint8_t>(backend_->CalibrationStatus().status));
  }

  // startRoutine
  const RoutineConditions conditions = backend_->Conditions();
  if (session_routine) {
    if (size != 4 + kCalibrateOptionSize) return Fail(kNrcIncorrectMessageLength);
    CalibrateOptions options;
    if (req[4] > static_cast<uint8_t>(CalibrationMode::kStatic)) {
      return Fail(kNrcRequestOutOfRange);
    }
    options.mode = static_cast<CalibrationMode>(req[4]);
    options.max_duration_s = U16(&req[5]);
    options.verify_only = rid == kRoutineVerify;
    if (options.max_duration_s > kMaxCalibrationDurationS) return Fail(kNrcRequestOutOfRange);
    if (!conditions.interlock_asserted || !conditions.lidar_alive || !conditions.camera_alive) {
      return Fail(kNrcConditionsNotCorrect);
    }
    const Nrc nrc = FromBackend(backend_->StartCalibration(options));
    if (nrc != kNrcNone) return Fail(nrc);
    calibrate_started_ = true;
    routine_started_in_session_ = true;
    suppress_positive_ = suppress;
    return RoutineReply(req, static_cast<uint8_t>(RoutineStatus::kActive));
  }
  if (size != 4) return Fail(kNrcIncorrectMessageLength);
  if (!conditions.interlock_asserted) return Fail(kNrcConditionsNotCorrect);
  const BackendReply reply = rid == kRoutineCommit             ? backend_->Commit()
                             : rid == kRoutineRestoreReference ? backend_->RestoreReference()
                                                               : backend_->StoreReference();
  const Nrc nrc = FromBackend(reply);
  RoutineStatus& last = StoreRoutineStatus(rid);
  if (nrc == kNrcGeneralProgrammingFailure) last = RoutineStatus::kFailed;
  if (nrc != kNrcNone) return Fail(nrc);
  last = RoutineStatus::kSuccess;
  suppress_positive_ = suppress;
  return RoutineReply(req, static_cast<uint8_t>(last));
}

RoutineStatus& UdsServer::StoreRoutineStatus(uint16_t rid) {
  return rid == kRoutineCommit             ? commit_status_
         : rid == kRoutineRestoreReference ? restore_status_
                                           : store_reference_status_;
}

// ISO 14229-1 §9.5 TesterPresent: zeroSubFunction only.
size_t UdsServer::TesterPresent(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  if ((req[1] & ~kSuppressPosRspBit) != 0x00) return Fail(kNrcSubFunctionNotSupported);
  if (size != 2) return Fail(kNrcIncorrectMessageLength);
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  buffer_[0] = kSidTesterPresent + kPositiveResponseOffset;
  buffer_[1] = 0x00;
  return 2;
}

// ISO 14229-1 §9.9 ControlDTCSetting: 01 on, 02 off (no DTCSettingControlOptionRecord).
size_t UdsServer::ControlDtcSetting(const uint8_t* req, size_t size) {
  if (size < 2) return Fail(kNrcIncorrectMessageLength);
  const uint8_t type = req[1] & ~kSuppressPosRspBit;
  if (type != 0x01 && type != 0x02) return Fail(kNrcSubFunctionNotSupported);
  if (size != 2) return Fail(kNrcIncorrectMessageLength);
  dtcs_.SetEnabled(type == 0x01);
  suppress_positive_ = (req[1] & kSuppressPosRspBit) != 0;
  buffer_[0] = kSidControlDtcSetting + kPositiveResponseOffset;
  buffer_[1] = type;
  return 2;
}

}  // namespace calibd::uds
