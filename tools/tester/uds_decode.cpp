#include "uds_decode.hpp"

#include <cctype>
#include <cstdio>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/uds/did_codec.hpp"
#include "calibd/agent/uds/dtc_store.hpp"
#include "calibd/agent/uds/routines.hpp"
#include "calibd/agent/uds/uds_types.hpp"

namespace calibd::tester {
namespace {

struct NrcInfo {
  uint8_t nrc;
  const char* name;
  const char* meaning;
};

// ISO 14229-1 Annex A.1 Table A.1 (the codes a tester meets in practice).
constexpr NrcInfo kNrcs[] = {
    {0x10, "generalReject", "the ECU rejected the request without a specific reason"},
    {0x11, "serviceNotSupported", "the ECU does not implement this service"},
    {0x12, "subFunctionNotSupported", "the ECU does not implement this sub-function"},
    {0x13, "incorrectMessageLengthOrInvalidFormat", "the request has the wrong length or format"},
    {0x14, "responseTooLong", "the response would exceed the transport's maximum length"},
    {0x21, "busyRepeatRequest", "the ECU is busy; repeat the request later"},
    {0x22, "conditionsNotCorrect", "the ECU's preconditions for this request are not met"},
    {0x24, "requestSequenceError", "the request came out of the expected order"},
    {0x25, "noResponseFromSubnetComponent", "a component behind the ECU did not answer"},
    {0x26, "failurePreventsExecutionOfRequestedAction", "a fault prevents the action"},
    {0x31, "requestOutOfRange", "an identifier or value in the request is not supported"},
    {0x33, "securityAccessDenied", "the ECU is locked for this request"},
    {0x35, "invalidKey", "the key does not match the seed"},
    {0x36, "exceededNumberOfAttempts", "too many wrong keys: security access is locked out"},
    {0x37, "requiredTimeDelayNotExpired", "the lockout delay after wrong keys is still running"},
    {0x70, "uploadDownloadNotAccepted", "the transfer was not accepted"},
    {0x71, "transferDataSuspended", "the transfer was suspended"},
    {0x72, "generalProgrammingFailure", "the ECU failed to write its memory"},
    {0x73, "wrongBlockSequenceCounter", "the transfer's block counter is wrong"},
    {0x78, "requestCorrectlyReceived-ResponsePending", "the ECU needs more time (up to P2*)"},
    {0x7E, "subFunctionNotSupportedInActiveSession",
     "the sub-function is not available in the current diagnostic session"},
    {0x7F, "serviceNotSupportedInActiveSession",
     "the service is not available in the current diagnostic session"},
    {0x92, "voltageTooHigh", "the supply voltage is too high"},
    {0x93, "voltageTooLow", "the supply voltage is too low"},
};

const NrcInfo* FindNrc(uint8_t nrc) {
  for (const NrcInfo& info : kNrcs)
    if (info.nrc == nrc) return &info;
  return nullptr;
}

std::string Hex2(unsigned v) {
  char buf[8];
  std::snprintf(buf, sizeof(buf), "0x%02X", v & 0xFFu);
  return buf;
}

int32_t GetI32(const uint8_t* p) {
  const uint32_t u = (uint32_t{p[0]} << 24) | (uint32_t{p[1]} << 16) | (uint32_t{p[2]} << 8) | p[3];
  return static_cast<int32_t>(u);
}
uint16_t GetU16(const uint8_t* p) { return static_cast<uint16_t>((p[0] << 8) | p[1]); }

std::string Ascii(const uint8_t* data, size_t size) {
  std::string s;
  for (size_t i = 0; i < size; ++i) s += std::isprint(data[i]) ? static_cast<char>(data[i]) : '?';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s.empty() ? "(empty)" : s;
}

std::string Format(const char* fmt, double a) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), fmt, a);
  return buf;
}

std::string DecodeExtrinsic(const uint8_t* p) {
  int32_t v[6];
  bool all_na = true;
  for (int i = 0; i < 6; ++i) {
    v[i] = GetI32(p + 4 * i);
    all_na = all_na && v[i] == uds::kExtrinsicNotAvailable;
  }
  if (all_na) return "not available";
  const double mm = uds::kTranslationLsbM * 1000.0, deg = uds::kAngleLsbDeg;
  return Format("x %.2f mm", v[0] * mm) + Format(", y %.2f mm", v[1] * mm) +
         Format(", z %.2f mm", v[2] * mm) + Format(", roll %.6f deg", v[3] * deg) +
         Format(", pitch %.6f deg", v[4] * deg) + Format(", yaw %.6f deg", v[5] * deg);
}

// The predicted 99 % error bound of DID 0xFD02 (did_codec.hpp).
std::string DecodeBound(const uint8_t* p) {
  if (GetU16(p) == uds::kBoundNotAvailable || GetU16(p + 2) == uds::kBoundNotAvailable)
    return ", error bound (99 %) not known";
  return Format(", error bound (99 %%) %.3f deg", GetU16(p) * uds::kRotationFigureLsbDeg) +
         Format(" / %.1f mm", GetU16(p + 2) * uds::kLengthFigureLsbM * 1000);
}

std::string DecodeQuality(const uint8_t* p) {
  return Format("reprojection mean %.2f px", GetU16(p) * uds::kReprojectionLsbPx) +
         Format(", LiDAR residual RMS %.1f mm", GetU16(p + 2) * uds::kLengthFigureLsbM * 1000) +
         Format(", rotation sigma %.3f deg", GetU16(p + 4) * uds::kRotationFigureLsbDeg) +
         Format(", translation sigma %.1f mm", GetU16(p + 6) * uds::kLengthFigureLsbM * 1000) +
         ", frames " + std::to_string(GetU16(p + 8)) + ", boards " +
         std::to_string(GetU16(p + 10)) + DecodeBound(p + 12);
}

std::string DecodeBcdDate(const uint8_t* p) {
  if (p[0] == 0 && p[1] == 0 && p[2] == 0 && p[3] == 0) return "none";
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%02X%02X-%02X-%02X", p[0], p[1], p[2], p[3]);
  return buf;
}

const char* CalibrationStateName(uint8_t state) {
  switch (state) {
    case 0:
      return "valid";
    case 1:
      return "not performed";
    case 2:
      return "recalibration required";
    default:
      return "unknown state";
  }
}

}  // namespace

const char* ServiceName(uint8_t sid) {
  switch (sid) {
    case uds::kSidDiagnosticSessionControl:
      return "DiagnosticSessionControl";
    case uds::kSidEcuReset:
      return "ECUReset";
    case uds::kSidClearDiagnosticInformation:
      return "ClearDiagnosticInformation";
    case uds::kSidReadDtcInformation:
      return "ReadDTCInformation";
    case uds::kSidReadDataByIdentifier:
      return "ReadDataByIdentifier";
    case uds::kSidSecurityAccess:
      return "SecurityAccess";
    case uds::kSidWriteDataByIdentifier:
      return "WriteDataByIdentifier";
    case uds::kSidRoutineControl:
      return "RoutineControl";
    case uds::kSidTesterPresent:
      return "TesterPresent";
    case uds::kSidControlDtcSetting:
      return "ControlDTCSetting";
    default:
      return "unknown service";
  }
}

const char* NrcName(uint8_t nrc) {
  const NrcInfo* info = FindNrc(nrc);
  return info ? info->name : "unknown NRC";
}

const char* NrcMeaning(uint8_t nrc) {
  const NrcInfo* info = FindNrc(nrc);
  return info ? info->meaning : "a code this tester does not know (ISO 14229-1 Annex A.1)";
}

std::string NrcHint(uint8_t sid, uint8_t nrc) {
  switch (nrc) {
    case uds::kNrcSecurityAccessDenied:
      return "unlock first: calibd-tester --secret FILE <command>";
    case uds::kNrcServiceNotSupportedInActiveSession:
    case uds::kNrcSubFunctionNotSupportedInActiveSession:
      return "switch to the extended session first: calibd-tester session extended";
    case uds::kNrcInvalidKey:
      return "the secret file does not match this vehicle's";
    case uds::kNrcExceededNumberOfAttempts:
      return "locked out: wait for the delay to expire before unlocking again";
    case uds::kNrcRequiredTimeDelayNotExpired:
      return "locked out after wrong keys: wait and try again";
    case uds::kNrcRequestSequenceError:
      if (sid == uds::kSidRoutineControl)
        return "nothing to report, stop or commit yet: start a calibration first";
      if (sid == uds::kSidSecurityAccess) return "request a seed before sending a key";
      return "";
    case uds::kNrcConditionsNotCorrect:
      if (sid == uds::kSidRoutineControl)
        return "check the interlock, that LiDAR and camera are sending and that no calibration "
               "is running";
      return "";
    default:
      return "";
  }
}

std::string DescribeNegativeResponse(uint8_t sid, uint8_t nrc) {
  std::string text = Hex2(sid) + " " + ServiceName(sid) + " refused: " + Hex2(nrc) + " " +
                     NrcName(nrc) + ": " + NrcMeaning(nrc);
  const std::string hint = NrcHint(sid, nrc);
  if (!hint.empty()) text += " (" + hint + ")";
  return text;
}

std::string FormatDtc(uint32_t number) {
  static constexpr char kLetters[] = {'P', 'C', 'B', 'U'};
  char buf[16];
  std::snprintf(buf, sizeof(buf), "%c%X%03X-%02X", kLetters[(number >> 22) & 3],
                (number >> 20) & 3u, (number >> 8) & 0xFFFu, number & 0xFFu);
  return buf;
}

const char* DtcName(uint32_t number) {
  static constexpr const char* kNames[uds::kDtcCount] = {"calibration not performed",
                                                         "calibration result rejected",
                                                         "recalibration required (sensor replaced)",
                                                         "LiDAR data timeout",
                                                         "camera data timeout",
                                                         "calibration store corrupt",
                                                         "CAN bus-off",
                                                         "calibration store write failed",
                                                         "calibration session interrupted"};
  const int index = uds::DtcStore::IndexOf(number);
  return index < 0 ? "not a calibd DTC" : kNames[index];
}

std::string DescribeDtcStatus(uint8_t status) {
  static constexpr const char* kBits[8] = {"testFailed",
                                           "testFailedThisOperationCycle",
                                           "pendingDTC",
                                           "confirmedDTC",
                                           "testNotCompletedSinceLastClear",
                                           "testFailedSinceLastClear",
                                           "testNotCompletedThisOperationCycle",
                                           "warningIndicatorRequested"};
  std::string text;
  for (int bit = 0; bit < 8; ++bit) {
    if (!(status & (1u << bit))) continue;
    if (!text.empty()) text += ", ";
    text += kBits[bit];
  }
  return text.empty() ? "none" : text;
}

bool ParseDid(const std::string& text, uint16_t* did) {
  std::string digits = text;
  if (digits.size() > 2 && digits[0] == '0' && (digits[1] == 'x' || digits[1] == 'X'))
    digits = digits.substr(2);
  if (digits.empty() || digits.size() > 4) return false;
  unsigned value = 0;
  for (char c : digits) {
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
    value = value * 16 + static_cast<unsigned>(std::isdigit(static_cast<unsigned char>(c))
                                                   ? c - '0'
                                                   : std::toupper(c) - 'A' + 10);
  }
  *did = static_cast<uint16_t>(value);
  return true;
}

size_t DidSize(uint16_t did) {
  switch (did) {
    case uds::kDidEcuSerial:
      return uds::kEcuSerialSize;
    case uds::kDidVin:
      return uds::kVinSize;
    case uds::kDidSoftwareVersion:
      return uds::kSoftwareVersionSize;
    case uds::kDidCalibrationDate:
      return 4;
    case uds::kDidCurrentExtrinsic:
    case uds::kDidReferenceExtrinsic:
      return uds::kExtrinsicSize;
    case uds::kDidQualityFigures:
      return uds::kQualitySize;
    case uds::kDidLidarSerial:
    case uds::kDidCameraSerial:
      return uds::kSensorSerialSize;
    case uds::kDidCalibrationState:
      return 2;
    case uds::kDidCaptureCoverage:
      return uds::kCoverageSize;
    default:
      return 0;
  }
}

const char* DidName(uint16_t did) {
  switch (did) {
    case uds::kDidEcuSerial:
      return "ECU serial number";
    case uds::kDidVin:
      return "VIN";
    case uds::kDidSoftwareVersion:
      return "software version";
    case uds::kDidCalibrationDate:
      return "calibration date";
    case uds::kDidCurrentExtrinsic:
      return "current T_camera_lidar";
    case uds::kDidReferenceExtrinsic:
      return "reference T_camera_lidar";
    case uds::kDidQualityFigures:
      return "quality";
    case uds::kDidLidarSerial:
      return "LiDAR serial number";
    case uds::kDidCameraSerial:
      return "camera serial number";
    case uds::kDidCalibrationState:
      return "calibration state";
    case uds::kDidCaptureCoverage:
      return "capture coverage";
    default:
      return "unknown DID";
  }
}

std::string DecodeDid(uint16_t did, const uint8_t* data, size_t size) {
  if (DidSize(did) == 0 || size != DidSize(did)) return FormatHex(data, size);
  switch (did) {
    case uds::kDidCalibrationDate:
      return DecodeBcdDate(data);
    case uds::kDidCurrentExtrinsic:
    case uds::kDidReferenceExtrinsic:
      return DecodeExtrinsic(data);
    case uds::kDidQualityFigures:
      return DecodeQuality(data);
    case uds::kDidCalibrationState:
      return std::string(CalibrationStateName(data[0])) + ", calibrate routine " +
             RoutineStatusName(data[1]);
    case uds::kDidCaptureCoverage:
      return CoverageSummary(uds::DecodeCoverage(data));
    default:
      return Ascii(data, size);
  }
}

std::string CoverageSummary(const CaptureCoverage& c) {
  const int bins = DistanceBinsSeen(c), cells = ImageCellsSeen(c);
  char line[192];
  std::snprintf(line, sizeof(line),
                "%s session, distance bins %d of %d (%d needed), image cells %d of %d (%d "
                "needed), frame pairs %d (%d needed, target %d), boards %d (%d needed)",
                c.moving ? "moving" : "static", bins, kDistanceBins, c.gates.min_distance_bins,
                cells, kImageCells, c.gates.min_image_cells, c.frames_with_boards,
                c.gates.min_frames, c.gates.target_frames, c.boards, c.gates.min_boards);
  return line;
}

std::string CoverageChart(const CaptureCoverage& c) {
  std::string s = "distance bins:";
  for (int b = 0; b < kDistanceBins; ++b) {
    s += (c.distance_bins >> b) & 1u ? "  [x] " : "  [ ] ";
    s += DistanceBinName(b);
  }
  s += "   (" + std::to_string(c.gates.min_distance_bins) + " needed)\n";
  s += "image cells (x: a board centre seen; " + std::to_string(c.gates.min_image_cells) +
       " needed):\n";
  for (int row = 0; row < kImageGridSide; ++row) {
    s += "  ";
    for (int col = 0; col < kImageGridSide; ++col)
      s += (c.image_cells >> (row * kImageGridSide + col)) & 1u ? " x" : " .";
    s += "\n";
  }
  s += "frame pairs with boards: " + std::to_string(c.frames_with_boards) + " (" +
       std::to_string(c.gates.min_frames) + " needed, target " +
       std::to_string(c.gates.target_frames) + "), boards: " + std::to_string(c.boards) + " (" +
       std::to_string(c.gates.min_boards) + " needed)\n";
  s += "next: ";
  AppendCaptureGuidance(c, &s);
  s += "\n";
  return s;
}

const char* RoutineStatusName(uint8_t status) {
  switch (static_cast<uds::RoutineStatus>(status)) {
    case uds::RoutineStatus::kIdle:
      return "idle";
    case uds::RoutineStatus::kActive:
      return "active";
    case uds::RoutineStatus::kSuccess:
      return "success";
    case uds::RoutineStatus::kAborted:
      return "aborted";
    case uds::RoutineStatus::kFailed:
      return "failed";
  }
  return "unknown status";
}

const char* RoutineVerdictName(uint8_t verdict) {
  switch (static_cast<uds::RoutineVerdict>(verdict)) {
    case uds::RoutineVerdict::kNone:
      return "none";
    case uds::RoutineVerdict::kVerified:
      return "verified";
    case uds::RoutineVerdict::kUpdated:
      return "updated";
    case uds::RoutineVerdict::kRejected:
      return "rejected";
  }
  return "unknown verdict";
}

const char* RoutineReasonName(uint8_t code) {
  const Reason reason = ReasonFromCode(code);
  if (reason == Reason::kNone) return "none";
  if (reason == Reason::kOther)
    return code == 0xFF ? "other (see the agent's log)" : "unknown reason";
  return NameOf(reason).data();  // the table's names are string literals
}

bool ParseHex(const std::string& text, std::vector<uint8_t>* bytes) {
  bytes->clear();
  std::string digits;
  for (size_t i = 0; i < text.size(); ++i) {
    const char c = text[i];
    if (c == ' ' || c == ',' || c == ':') continue;
    if (c == '0' && i + 1 < text.size() && (text[i + 1] == 'x' || text[i + 1] == 'X')) {
      ++i;
      continue;
    }
    if (!std::isxdigit(static_cast<unsigned char>(c))) return false;
    digits += c;
  }
  if (digits.empty() || digits.size() % 2 != 0) return false;
  for (size_t i = 0; i < digits.size(); i += 2)
    bytes->push_back(static_cast<uint8_t>(std::stoul(digits.substr(i, 2), nullptr, 16)));
  return true;
}

std::string FormatHex(const uint8_t* data, size_t size) {
  std::string text;
  char buf[4];
  for (size_t i = 0; i < size; ++i) {
    std::snprintf(buf, sizeof(buf), i ? " %02X" : "%02X", data[i]);
    text += buf;
  }
  return text;
}

}  // namespace calibd::tester
