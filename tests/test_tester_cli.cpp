// calibd-tester's pure parts (tools/tester): NRC names and hints, DID and DTC decoding, hex, and
// the command line's errors. The bus side runs in the VM (tests/vm/uds_tester_vmtest.cpp).

#include <gtest/gtest.h>

#include <string>
#include <vector>

#include "calibd/agent/uds/did_codec.hpp"
#include "calibd/agent/uds/dtc_store.hpp"
#include "calibd/agent/uds/routines.hpp"
#include "tester_cli.hpp"
#include "uds_decode.hpp"

namespace calibd::tester {
namespace {

TEST(TesterNrc, NamesFromTheStandard) {
  EXPECT_STREQ(NrcName(0x33), "securityAccessDenied");
  EXPECT_STREQ(NrcName(0x24), "requestSequenceError");
  EXPECT_STREQ(NrcName(0x78), "requestCorrectlyReceived-ResponsePending");
  EXPECT_STREQ(NrcName(0x7F), "serviceNotSupportedInActiveSession");
  EXPECT_STREQ(NrcName(0x36), "exceededNumberOfAttempts");
  EXPECT_STREQ(NrcName(0xEE), "unknown NRC");
  EXPECT_STREQ(ServiceName(0x31), "RoutineControl");
  EXPECT_STREQ(ServiceName(0x99), "unknown service");
}

TEST(TesterNrc, MessageNamesServiceCodeAndWhatToDo) {
  EXPECT_EQ(DescribeNegativeResponse(0x31, 0x33),
            "0x31 RoutineControl refused: 0x33 securityAccessDenied: the ECU is locked for this "
            "request (unlock first: calibd-tester --secret FILE <command>)");
  const std::string sequence = DescribeNegativeResponse(0x31, 0x24);
  EXPECT_NE(sequence.find("0x24 requestSequenceError"), std::string::npos);
  EXPECT_NE(sequence.find("start a calibration first"), std::string::npos);
  EXPECT_NE(DescribeNegativeResponse(0x27, 0x36).find("locked out"), std::string::npos);
  // No hint: the meaning alone, no empty parentheses.
  EXPECT_EQ(DescribeNegativeResponse(0x22, 0x31),
            "0x22 ReadDataByIdentifier refused: 0x31 requestOutOfRange: an identifier or value in "
            "the request is not supported");
}

TEST(TesterDtc, J2012NumbersAndNames) {
  EXPECT_EQ(FormatDtc(0x5A0054), "C1A00-54");
  EXPECT_EQ(FormatDtc(0x5A0287), "C1A02-87");
  EXPECT_EQ(FormatDtc(0xC00188), "U0001-88");
  EXPECT_EQ(FormatDtc(0x012345), "P0123-45");
  EXPECT_STREQ(DtcName(0x5A0054), "calibration not performed");
  EXPECT_STREQ(DtcName(0xC00188), "CAN bus-off");
  EXPECT_STREQ(DtcName(0x123456), "not a calibd DTC");
  // Every DTC of the store has a name.
  for (uint32_t number : uds::kDtcNumbers) EXPECT_STRNE(DtcName(number), "not a calibd DTC");
}

TEST(TesterDtc, StatusBits) {
  EXPECT_EQ(DescribeDtcStatus(0x00), "none");
  EXPECT_EQ(DescribeDtcStatus(uds::kDtcStatusAfterClear),
            "testNotCompletedSinceLastClear, testNotCompletedThisOperationCycle");
  EXPECT_EQ(DescribeDtcStatus(0x2F),
            "testFailed, testFailedThisOperationCycle, pendingDTC, confirmedDTC, "
            "testFailedSinceLastClear");
  EXPECT_EQ(DescribeDtcStatus(0x80), "warningIndicatorRequested");
}

TEST(TesterDid, ExtrinsicRoundTripsTheServersEncoding) {
  uds::ExtrinsicFigures e;
  e.available = true;
  e.x_m = 0.12345;
  e.y_m = -0.05;
  e.z_m = 1.5;
  e.roll_deg = 0.5;
  e.pitch_deg = -1.25;
  e.yaw_deg = 90.000001;
  uint8_t bytes[uds::kExtrinsicSize];
  ASSERT_EQ(uds::EncodeExtrinsic(e, bytes), uds::kExtrinsicSize);
  EXPECT_EQ(DecodeDid(0xFD00, bytes, sizeof(bytes)),
            "x 123.45 mm, y -50.00 mm, z 1500.00 mm, roll 0.500000 deg, pitch -1.250000 deg, yaw "
            "90.000001 deg");
  uds::EncodeExtrinsic(uds::ExtrinsicFigures{}, bytes);
  EXPECT_EQ(DecodeDid(0xFD01, bytes, sizeof(bytes)), "not available");
}

TEST(TesterDid, TextDateQualityStateAndUnknown) {
  uint8_t vin[uds::kVinSize];
  uds::PutPaddedAscii(vin, "WVWZZZ1KZAW000001", sizeof(vin));
  EXPECT_EQ(DecodeDid(0xF190, vin, sizeof(vin)), "WVWZZZ1KZAW000001");
  uint8_t serial[uds::kSensorSerialSize];
  uds::PutPaddedAscii(serial, "OT128-0042", sizeof(serial));
  EXPECT_EQ(DecodeDid(0xFD03, serial, sizeof(serial)), "OT128-0042");
  uint8_t date[4];
  uds::EncodeBcdDate(1'700'000'000, date);  // 2023-11-14 UTC
  EXPECT_EQ(DecodeDid(0xF19B, date, 4), "2023-11-14");
  uds::EncodeBcdDate(0, date);
  EXPECT_EQ(DecodeDid(0xF19B, date, 4), "none");
  uds::QualityFigures q;
  q.reprojection_mean_px = 0.42;
  q.residual_rms_m = 0.0123;
  q.rotation_sigma_deg = 0.015;
  q.translation_sigma_m = 0.0021;
  q.frames_used = 180;
  q.boards_used = 3;
  uint8_t quality[uds::kQualitySize];
  EXPECT_EQ(uds::EncodeQuality(q, quality), sizeof(quality));
  EXPECT_EQ(DecodeDid(0xFD02, quality, sizeof(quality)),
            "reprojection mean 0.42 px, LiDAR residual RMS 12.3 mm, rotation sigma 0.015 deg, "
            "translation sigma 2.1 mm, frames 180, boards 3, error bound (99 %) not known");
  q.rotation_bound_deg = 0.1234;
  q.translation_bound_m = 0.0125;
  uds::EncodeQuality(q, quality);
  EXPECT_EQ(quality[12], 0x00);  // 123 x 0.001 deg
  EXPECT_EQ(quality[13], 123);
  EXPECT_EQ(quality[14], 0x00);  // 125 x 0.1 mm
  EXPECT_EQ(quality[15], 125);
  EXPECT_EQ(DecodeDid(0xFD02, quality, sizeof(quality)),
            "reprojection mean 0.42 px, LiDAR residual RMS 12.3 mm, rotation sigma 0.015 deg, "
            "translation sigma 2.1 mm, frames 180, boards 3, error bound (99 %) 0.123 deg / 12.5 "
            "mm");
  const uint8_t state[2] = {2, 1};
  EXPECT_EQ(DecodeDid(0xFD05, state, 2), "recalibration required, calibrate routine active");
  const uint8_t other[3] = {0xAB, 0x01, 0x02};
  EXPECT_EQ(DecodeDid(0x1234, other, 3), "AB 01 02");
  EXPECT_EQ(DecodeDid(0xFD05, other, 3), "AB 01 02");  // wrong size: bytes as they are
  EXPECT_EQ(DidSize(0x1234), 0u);
  EXPECT_EQ(DidSize(0xFD00), 24u);
}

// DID 0xFD06 as the agent encodes it, shown to the operator: the bins and the image grid with
// what is covered, and the agent's own guidance for what is missing.
TEST(TesterDid, CaptureCoverageShowsWhereBoardsAreMissing) {
  CaptureCoverage c;
  c.moving = false;
  c.distance_bins = 0b0001;                           // only 0-8.5 m
  c.image_cells = (1u << 0) | (1u << 1) | (1u << 4);  // three cells of the top-left quadrant
  c.frames_with_boards = 12;
  c.boards = 30;
  c.gates = {200, 50, 20, 3, 4};  // target, frames, boards, bins, cells
  uint8_t bytes[uds::kCoverageSize];
  ASSERT_EQ(uds::EncodeCoverage(c, bytes), uds::kCoverageSize);
  EXPECT_EQ(DidSize(0xFD06), uds::kCoverageSize);
  EXPECT_EQ(DecodeDid(0xFD06, bytes, sizeof(bytes)),
            "static session, distance bins 1 of 4 (3 needed), image cells 3 of 16 (4 needed), "
            "frame pairs 12 (50 needed, target 200), boards 30 (20 needed)");
  EXPECT_EQ(CoverageChart(uds::DecodeCoverage(bytes)),
            "distance bins:  [x] 0-8.5 m  [ ] 8.5-15 m  [ ] 15-25 m  [ ] 25+ m   (3 needed)\n"
            "image cells (x: a board centre seen; 4 needed):\n"
            "   x x . .\n"
            "   x . . .\n"
            "   . . . .\n"
            "   . . . .\n"
            "frame pairs with boards: 12 (50 needed, target 200), boards: 30 (20 needed)\n"
            "next: move boards to 8.5-15 m, 15-25 m, 25+ m (1 of 4 distance bins, 3 needed); "
            "boards needed in the image's top-right, bottom-left, bottom-right (3 of 16 image "
            "cells, 4 needed)\n");
  // Covered: what is still short.
  c.distance_bins = 0b1110;
  c.image_cells = 0xF00F;
  EXPECT_NE(CoverageChart(c).find("next: coverage complete: keep collecting (12 of 50 frame "
                                  "pairs)"),
            std::string::npos);
}

TEST(TesterHex, ParseAndFormat) {
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(ParseHex("22 F1 90", &bytes));
  EXPECT_EQ(bytes, (std::vector<uint8_t>{0x22, 0xF1, 0x90}));
  ASSERT_TRUE(ParseHex("3e00", &bytes));
  EXPECT_EQ(bytes, (std::vector<uint8_t>{0x3E, 0x00}));
  ASSERT_TRUE(ParseHex("0x10,0x03", &bytes));
  EXPECT_EQ(bytes, (std::vector<uint8_t>{0x10, 0x03}));
  EXPECT_FALSE(ParseHex("22F", &bytes));
  EXPECT_FALSE(ParseHex("zz", &bytes));
  EXPECT_FALSE(ParseHex("", &bytes));
  EXPECT_EQ(FormatHex(bytes.data(), 0), "");
  const uint8_t r[3] = {0x7F, 0x31, 0x33};
  EXPECT_EQ(FormatHex(r, 3), "7F 31 33");
  uint16_t did = 0;
  EXPECT_TRUE(ParseDid("0xfd00", &did));
  EXPECT_EQ(did, 0xFD00);
  EXPECT_FALSE(ParseDid("FD000", &did));
  EXPECT_FALSE(ParseDid("G1", &did));
}

/// Parses and returns the error ("" when it parsed).
std::string ParseError(const std::vector<std::string>& args, TesterOptions* o = nullptr) {
  TesterOptions local;
  bool help = false;
  std::string error;
  if (ParseTesterArgs(args, o ? o : &local, &help, &error)) return "";
  EXPECT_FALSE(error.empty());
  return error;
}

TEST(TesterArgs, GoodCommandLines) {
  TesterOptions o;
  ASSERT_EQ(ParseError({"--interface", "vcan0", "--ids", "18DA10F1,18DAF110,18DB33F1",
                        "--extended-ids", "calibrate", "--static", "--max-duration", "90"},
                       &o),
            "");
  EXPECT_EQ(o.isotp.interface, "vcan0");
  EXPECT_EQ(o.isotp.physical_request_id, 0x18DA10F1u);
  EXPECT_EQ(o.isotp.functional_request_id, 0x18DB33F1u);
  EXPECT_TRUE(o.isotp.extended_ids);
  EXPECT_EQ(o.command, "calibrate");
  EXPECT_TRUE(o.static_mode);
  EXPECT_EQ(o.max_duration_s, 90);
  EXPECT_EQ(ParseError({"read", "F190,FD00"}), "");
  EXPECT_EQ(ParseError({"raw", "22", "F1", "90", "--functional"}), "");
  EXPECT_EQ(ParseError({"--secret", "/etc/calibd/secret", "unlock"}), "");
  EXPECT_EQ(ParseError({"unlock", "--secret", "/etc/calibd/secret"}), "");
  EXPECT_EQ(ParseError({"write-vin", "WVWZZZ1KZAW000001"}), "");
  TesterOptions h;
  bool help = false;
  std::string error;
  EXPECT_TRUE(ParseTesterArgs({"session", "--help"}, &h, &help, &error));
  EXPECT_TRUE(help);
}

TEST(TesterArgs, ErrorsSayWhatIsWrong) {
  EXPECT_EQ(ParseError({}), "no command given (see --help)");
  EXPECT_EQ(ParseError({"flash"}), "unknown command 'flash' (see --help)");
  EXPECT_EQ(ParseError({"session", "programming"}),
            "session must be default or extended (got 'programming')");
  EXPECT_EQ(ParseError({"session"}), "usage: calibd-tester session default|extended");
  EXPECT_EQ(ParseError({"unlock"}),
            "unlock needs --secret FILE (the vehicle's SecurityAccess secret)");
  EXPECT_EQ(ParseError({"--interface"}), "option --interface needs a value (see --help)");
  EXPECT_EQ(ParseError({"--bogus", "dtc"}), "unknown option '--bogus' (see --help)");
  EXPECT_NE(ParseError({"--ids", "7E0,7E8", "dtc"}).find("three hex ids"), std::string::npos);
  EXPECT_NE(ParseError({"calibrate", "--max-duration", "4000"}).find("[1, 3600]"),
            std::string::npos);
  EXPECT_NE(ParseError({"calibrate", "--max-duration", "ten"}).find("got 'ten'"),
            std::string::npos);
  EXPECT_EQ(ParseError({"--p2-ms", "x", "dtc"}),
            "--p2-ms must be an integer in [1, 600000] ms (got 'x')");
  EXPECT_EQ(ParseError({"--p2-ms=5", "dtc"}), "unknown option '--p2-ms=5' (see --help)");
  EXPECT_EQ(ParseError({"dtc", "--static"}),
            "--static, --max-duration and --no-wait go with calibrate or verify");
  EXPECT_EQ(ParseError({"read", "--clear", "F190"}), "--clear goes with dtc");
  EXPECT_NE(ParseError({"read", "F1X0"}).find("'F1X0' is not a DID"), std::string::npos);
  EXPECT_NE(ParseError({"write-vin", "WVWZZZ1KZAW00000I"}).find("17 characters"),
            std::string::npos);
  EXPECT_NE(ParseError({"raw", "2"}).find("whole bytes"), std::string::npos);
  // The ISO-TP config's own check: 11-bit ids without --extended-ids.
  EXPECT_NE(ParseError({"--ids", "18DA10F1,18DAF110,18DB33F1", "dtc"}), "");
}

// The tester names the results record's byte as the agent logs the reason, for every code.
TEST(RoutineReasonTest, EveryCodeRoundTripsBetweenAgentAndTester) {
  int named = 0;
  for (int code = 0x01; code < 0xFF; ++code) {
    const std::string name = RoutineReasonName(static_cast<uint8_t>(code));
    if (name == "unknown reason") continue;
    ++named;
    EXPECT_EQ(static_cast<int>(ReasonFromName(name)), code) << name;
  }
  EXPECT_EQ(named, 0x1C) << "codes 0x01..0x1C each have a name";
  EXPECT_EQ(std::string(RoutineReasonName(0x0F)), "commit_failed");  // once store_write_failed
  EXPECT_EQ(std::string(RoutineReasonName(0x1B)), "board_not_flat");
  EXPECT_EQ(std::string(RoutineReasonName(0x00)), "none");
  EXPECT_EQ(std::string(RoutineReasonName(0xFF)), "other (see the agent's log)");
}

}  // namespace
}  // namespace calibd::tester
