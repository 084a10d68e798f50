#pragma once
/// \file
/// What calibd-tester prints: names and meanings of UDS services and negative response codes
/// (ISO 14229-1 Annex A.1), decoded data identifiers (the scalings of calibd's did_codec.hpp),
/// DTC numbers and status bits (dtc_store.hpp, ISO 14229-1 Annex D.2), routine results
/// (routines.hpp), and hex in and out. Pure functions: host-tested (tests/test_tester_cli.cpp).

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "calibd/agent/capture_guidance.hpp"

namespace calibd::tester {

/// "RoutineControl" for 0x31; "unknown service" otherwise.
const char* ServiceName(uint8_t sid);
/// "securityAccessDenied" for 0x33 (the standard's mnemonic); "unknown NRC" otherwise.
const char* NrcName(uint8_t nrc);
/// One sentence on what the NRC means, e.g. "the ECU is locked for this request".
const char* NrcMeaning(uint8_t nrc);
/// What to do about `nrc` answered to `sid`, e.g. "unlock first: calibd-tester --secret FILE
/// <command>"; empty when there is nothing specific to say.
std::string NrcHint(uint8_t sid, uint8_t nrc);
/// "0x31 RoutineControl refused: 0x33 securityAccessDenied: the ECU is locked ... (hint)".
std::string DescribeNegativeResponse(uint8_t sid, uint8_t nrc);

/// "C1A00-54" for 0x5A0054 (SAE J2012: letter, 4 hex digits, failure type byte).
std::string FormatDtc(uint32_t number);
/// calibd's name of a DTC ("calibration not performed"), or "not a calibd DTC".
const char* DtcName(uint32_t number);
/// "testFailed, confirmedDTC" for 0x09; "none" for 0.
std::string DescribeDtcStatus(uint8_t status);

/// "F190" -> 0xF190 ("0x" prefix allowed). False unless 1-4 hex digits.
bool ParseDid(const std::string& text, uint16_t* did);
/// Size of a DID's record (did_codec.hpp); 0 when the DID is not one of calibd's.
size_t DidSize(uint16_t did);
/// "VIN" for 0xF190, "current T_camera_lidar" for 0xFD00; "unknown DID".
const char* DidName(uint16_t did);
/// The decoded value of one record, e.g. "x 12.34 mm, y ... roll 0.500000 deg ..." for 0xFD00,
/// the text without trailing spaces for serials. Unknown DIDs or wrong sizes: the hex bytes.
std::string DecodeDid(uint16_t did, const uint8_t* data, size_t size);

/// DID 0xFD06 on one line ("moving session, distance bins 2 of 4 (3 needed), ...").
std::string CoverageSummary(const CaptureCoverage& coverage);
/// DID 0xFD06 for the operator: the distance bins and the image grid with what is covered, the
/// counts, and the agent's own guidance text ("next: ...").
std::string CoverageChart(const CaptureCoverage& coverage);

const char* RoutineStatusName(uint8_t status);    ///< "idle", "active", "success", ...
const char* RoutineVerdictName(uint8_t verdict);  ///< "none", "verified", "updated", "rejected"
/// "too_few_frames", ... as the agent logs them (core reason.hpp), "none", "other (see the
/// agent's log)" or "unknown reason" (a code not in this tester's table).
const char* RoutineReasonName(uint8_t code);

/// "22 F1 90" / "22f190" / "0x22,0xF1" -> bytes. False unless whole bytes of hex digits.
bool ParseHex(const std::string& text, std::vector<uint8_t>* bytes);
/// "62 F1 90 ..." (upper case, one space between bytes).
std::string FormatHex(const uint8_t* data, size_t size);

}  // namespace calibd::tester
