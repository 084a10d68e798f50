// The cyclic status frame: CRC-8 SAE J1850 against AUTOSAR's published check values, the E2E
// profile 1 style protection (a flipped bit or a wrong data id is caught), the alive counter, and
// the layout against deploy/calibd.dbc as decoded by python3-canmatrix, a decoder we did not
// write.

#include "calibd/core/common/status_frame.hpp"

#include <gtest/gtest.h>

#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>
#include <string>
#include <vector>

#include "run_command.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

uint8_t Crc(std::vector<uint8_t> bytes) { return Crc8J1850(bytes.data(), bytes.size()); }

TEST(StatusFrameTest, Crc8J1850MatchesAutosarCheckValues) {
  // AUTOSAR SWS CRC Library, 8-bit SAE J1850 test vectors, and the catalogue's check value.
  EXPECT_EQ(Crc({0x00, 0x00, 0x00, 0x00}), 0x59);
  EXPECT_EQ(Crc({0xF2, 0x01, 0x83}), 0x37);
  EXPECT_EQ(Crc({0x0F, 0xAA, 0x00, 0x55}), 0x79);
  EXPECT_EQ(Crc({0x00, 0xFF, 0x55, 0x11}), 0xB8);
  EXPECT_EQ(Crc({0x33, 0x22, 0x55, 0xAA, 0xBB, 0xCC, 0xDD, 0xEE, 0xFF}), 0xCB);
  EXPECT_EQ(Crc({0x92, 0x6B, 0x55}), 0x8C);
  EXPECT_EQ(Crc({0xFF, 0xFF, 0xFF, 0xFF}), 0x74);
  EXPECT_EQ(Crc({'1', '2', '3', '4', '5', '6', '7', '8', '9'}), 0x4B);
}

StatusFrame Example() {
  StatusFrame s;
  s.state = StatusFrame::State::kCollecting;
  s.progress_percent = 42;
  s.last_verdict = StatusFrame::Verdict::kUpdated;
  s.calibration = StatusFrame::Calibration::kRecalibrationRequired;
  s.rotation_delta_deg = 5.0123;
  s.calibration_age_h = 1234.4;
  return s;
}

TEST(StatusFrameTest, RoundTripsAndQuantises) {
  const StatusFrameCheck d = DecodeStatusFrame(EncodeStatusFrame(Example(), 7));
  EXPECT_TRUE(d.crc_ok);
  EXPECT_EQ(d.counter, 7);
  EXPECT_EQ(d.status.state, StatusFrame::State::kCollecting);
  EXPECT_EQ(d.status.progress_percent, 42);
  EXPECT_EQ(d.status.last_verdict, StatusFrame::Verdict::kUpdated);
  EXPECT_EQ(d.status.calibration, StatusFrame::Calibration::kRecalibrationRequired);
  EXPECT_DOUBLE_EQ(d.status.rotation_delta_deg, 5.012);
  EXPECT_DOUBLE_EQ(d.status.calibration_age_h, 1234.0);

  StatusFrame none;  // nothing known yet: the "not available" codes
  const StatusFrameBytes b = EncodeStatusFrame(none, 0);
  EXPECT_EQ(b[2], 0xFF);
  EXPECT_EQ(b[4], 0xFF);
  EXPECT_EQ(b[5], 0xFF);
  EXPECT_EQ(b[6], 0xFF);
  EXPECT_EQ(b[7], 0xFF);
  EXPECT_EQ(DecodeStatusFrame(b).status.rotation_delta_deg, -1.0);
  StatusFrame huge = Example();  // saturates below the "not available" code
  huge.rotation_delta_deg = 1000.0;
  huge.calibration_age_h = 1e9;
  const StatusFrameBytes h = EncodeStatusFrame(huge, 0);
  EXPECT_EQ(h[4] | (h[5] << 8), 0xFFFE);
  EXPECT_EQ(h[6] | (h[7] << 8), 0xFFFE);
}

TEST(StatusFrameTest, CrcCatchesEveryFlippedBitAndAWrongDataId) {
  const StatusFrameBytes good = EncodeStatusFrame(Example(), 3);
  for (int byte = 0; byte < kStatusFrameBytes; ++byte)
    for (int bit = 0; bit < 8; ++bit) {
      StatusFrameBytes bad = good;
      bad[static_cast<size_t>(byte)] ^= static_cast<uint8_t>(1u << bit);
      EXPECT_FALSE(DecodeStatusFrame(bad).crc_ok) << "byte " << byte << " bit " << bit;
    }
  EXPECT_FALSE(DecodeStatusFrame(good, kStatusFrameDefaultDataId + 1).crc_ok);
}

TEST(StatusFrameTest, AliveCounterRunsZeroToFourteenAndWraps) {
  StatusFrameCounter counter;
  for (int i = 0; i < 40; ++i) {
    const int c = counter.Next();
    EXPECT_EQ(c, i % 15);
    EXPECT_EQ(DecodeStatusFrame(EncodeStatusFrame(Example(), c)).counter, i % 15);
  }
}

TEST(StatusFrameTest, TheDbcDecodesOurFramesAsWeDo) {
  testing::TempDir dir;
  std::vector<StatusFrame> cases{Example(), StatusFrame{}};
  cases.push_back(Example());
  cases.back().state = StatusFrame::State::kAborted;
  cases.back().calibration = StatusFrame::Calibration::kValid;
  cases.back().last_verdict = StatusFrame::Verdict::kRejected;
  cases.back().progress_percent = 100;
  std::vector<StatusFrameBytes> frames;
  {
    std::ofstream f(dir.file("frames.txt"));
    for (size_t i = 0; i < cases.size(); ++i) {
      frames.push_back(EncodeStatusFrame(cases[i], static_cast<int>(i) + 13));
      char line[64];
      int n = std::snprintf(line, sizeof(line), "3C0#");
      for (uint8_t b : frames.back()) n += std::snprintf(line + n, sizeof(line) - n, "%02X", b);
      f << line << "\n";
    }
  }
  const std::string out = dir.file("decoded.jsonl");
  ASSERT_EQ(
      testing::RunCommand("/usr/bin/python3 " + std::string(CALIBD_SOURCE_DIR) +
                          "/tests/dbc_decode.py " + CALIBD_SOURCE_DIR + "/deploy/calibd.dbc " +
                          dir.file("frames.txt") + " > " + out + " 2> " + dir.file("stderr.txt")),
      0)
      << "python3-canmatrix (Debian) decodes deploy/calibd.dbc";
  std::ifstream in(out);
  std::string line;
  size_t i = 0;
  for (; std::getline(in, line) && i < frames.size(); ++i) {
    const auto j = nlohmann::json::parse(line);
    const StatusFrameCheck d = DecodeStatusFrame(frames[i]);
    ASSERT_TRUE(d.crc_ok);
    EXPECT_EQ(j.at("Crc").get<int>(), frames[i][0]) << line;
    EXPECT_EQ(j.at("AliveCounter").get<int>(), d.counter) << line;
    EXPECT_EQ(j.at("State").get<int>(), static_cast<int>(cases[i].state)) << line;
    EXPECT_EQ(j.at("Progress").get<int>(), frames[i][2]) << line;
    EXPECT_EQ(j.at("LastVerdict").get<int>(), static_cast<int>(cases[i].last_verdict)) << line;
    EXPECT_EQ(j.at("CalibrationState").get<int>(), static_cast<int>(cases[i].calibration)) << line;
    EXPECT_EQ(j.at("RotationDelta").get<int>(), frames[i][4] | (frames[i][5] << 8)) << line;
    EXPECT_EQ(j.at("CalibrationAge").get<int>(), frames[i][6] | (frames[i][7] << 8)) << line;
  }
  EXPECT_EQ(i, frames.size()) << "every frame decoded";
  // The physical scaling: raw 5012 x 0.001 deg.
  EXPECT_EQ(frames[0][4] | (frames[0][5] << 8), 5012);
}

}  // namespace
}  // namespace calibd
