#pragma once
/// \file
/// UDS (ISO 14229-1) identifiers shared by the server's parts: service ids, negative response
/// codes (Annex A.1), sessions, and the response view UdsServer::Handle returns.

#include <cstddef>
#include <cstdint>

namespace calibd::uds {

/// Service identifiers (ISO 14229-1 §6, Table 2 / Annex A). A positive response is SID + 0x40.
enum Sid : uint8_t {
  kSidDiagnosticSessionControl = 0x10,
  kSidEcuReset = 0x11,
  kSidClearDiagnosticInformation = 0x14,
  kSidReadDtcInformation = 0x19,
  kSidReadDataByIdentifier = 0x22,
  kSidSecurityAccess = 0x27,
  kSidWriteDataByIdentifier = 0x2E,
  kSidRoutineControl = 0x31,
  kSidTesterPresent = 0x3E,
  kSidControlDtcSetting = 0x85,
  kSidNegativeResponse = 0x7F,
};
inline constexpr uint8_t kPositiveResponseOffset = 0x40;
/// suppressPosRspMsgIndicationBit: bit 7 of the sub-function byte (ISO 14229-1 §7.5.2).
inline constexpr uint8_t kSuppressPosRspBit = 0x80;

/// Negative response codes (ISO 14229-1 Annex A.1), the ones this server sends.
enum Nrc : uint8_t {
  kNrcNone = 0x00,  ///< internal: positive response
  kNrcServiceNotSupported = 0x11,
  kNrcSubFunctionNotSupported = 0x12,
  kNrcIncorrectMessageLength = 0x13,
  kNrcResponseTooLong = 0x14,
  kNrcConditionsNotCorrect = 0x22,
  kNrcRequestSequenceError = 0x24,
  kNrcRequestOutOfRange = 0x31,
  kNrcSecurityAccessDenied = 0x33,
  kNrcInvalidKey = 0x35,
  kNrcExceededNumberOfAttempts = 0x36,
  kNrcRequiredTimeDelayNotExpired = 0x37,
  kNrcResponsePending = 0x78,  ///< requestCorrectlyReceived-ResponsePending
  kNrcGeneralProgrammingFailure = 0x72,
  kNrcSubFunctionNotSupportedInActiveSession = 0x7E,
  kNrcServiceNotSupportedInActiveSession = 0x7F,
};

/// Diagnostic sessions (diagnosticSessionType, ISO 14229-1 §9.2.2.2). Programming (0x02) is
/// not supported: this ECU has no flash loader.
enum class Session : uint8_t { kDefault = 0x01, kExtended = 0x03 };

/// ISO 15765-2 with classic CAN carries at most 4095 bytes in one message: the server's response
/// buffer has that size and longer responses are refused with 0x14 responseTooLong.
inline constexpr size_t kMaxMessageSize = 4095;

/// What UdsServer::Handle produced: a view into the server's own buffer, valid until the next
/// Handle call. size 0: no response is to be sent (suppressed positive response, or a negative
/// response suppressed for a functional request, ISO 14229-1 §7.5).
struct Response {
  const uint8_t* data = nullptr;
  size_t size = 0;
  bool empty() const { return size == 0; }
  bool negative() const { return size == 3 && data[0] == kSidNegativeResponse; }
  uint8_t nrc() const { return negative() ? data[2] : uint8_t{0}; }
};

}  // namespace calibd::uds
