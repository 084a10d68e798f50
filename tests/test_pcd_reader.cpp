// PCD reader: round trips through a test writer in all three encodings with assorted field types,
// padding, unknown fields and NaN points; every malformed input refused with its own error.

#include "calibd/drivers/pcd_reader.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>
#include <random>

#include "pcd_writer.hpp"

namespace calibd {
namespace {

using testing::PcdFieldSpec;
using testing::PcdSpec;
using testing::WritePcd;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

// Fields x y z intensity ring <time> plus padding and an unknown 3-element field, 40 points of
// which 2 have a NaN coordinate.
struct Layout {
  std::string name;
  std::string data;  // encoding
  PcdFieldSpec x, intensity, ring, time;
  bool absolute_time = false;
};

PcdSpec MakeSpec(const Layout& l, std::vector<std::vector<double>>* expected) {
  PcdSpec s;
  PcdFieldSpec x = l.x, y = l.x, z = l.x;
  y.name = "y";
  z.name = "z";
  s.fields = {x, {"_", 'U', 1, 3}, y, z, l.intensity, {"normal", 'F', 4, 3}, l.ring, l.time};
  std::mt19937 rng(7);
  std::uniform_real_distribution<float> coord(-40.0f, 40.0f);
  for (int i = 0; i < 40; ++i) {
    const double px = coord(rng), py = coord(rng), pz = coord(rng);
    const double intensity = i % 200, ring = i % 128;
    const double t = l.time.type == 'F'
                         ? (l.absolute_time ? 1.7e9 + i * 1.25e-3 : static_cast<float>(i * 1e-3))
                         : i * 1234567.0;  // ns
    std::vector<double> row = {px, 0, 0, 0, py, i == 7 ? kNaN : pz};
    row.insert(row.end(), static_cast<size_t>(l.intensity.count), intensity);
    row.insert(row.end(), {0.5, 1.5, 2.5, ring, t});
    if (i == 21) row[0] = kNaN;
    s.rows.push_back(row);
    if (i == 7 || i == 21) continue;
    const double t_us =
        l.time.type == 'F' ? (l.absolute_time ? (t - 1.7e9) * 1e6 : t * 1e6) : t * 1e-3;
    expected->push_back({px, py, pz, intensity, ring, std::round(t_us)});
  }
  if (l.x.size == 4)
    for (auto& row : s.rows)
      for (int k : {0, 4, 5}) row[k] = static_cast<float>(row[k]);
  return s;
}

void PrintTo(const Layout& l, std::ostream* os) { *os << l.name; }

class PcdRoundTrip : public ::testing::TestWithParam<Layout> {};

TEST_P(PcdRoundTrip, PointsComeBackExactly) {
  const Layout& l = GetParam();
  std::vector<std::vector<double>> expected;
  const PcdSpec spec = MakeSpec(l, &expected);
  const std::string bytes = WritePcd(spec, l.data);
  ASSERT_FALSE(bytes.empty());
  lidar_frame_t cloud;
  PcdInfo info;
  std::string error;
  ASSERT_TRUE(ParsePcd(bytes, "t.pcd", PcdReadOptions{}, &cloud, &info, &error)) << error;
  EXPECT_EQ(info.data, l.data);
  EXPECT_EQ(info.version, "0.7");
  EXPECT_EQ(info.points, 40);
  EXPECT_EQ(info.nan_dropped, 2);
  EXPECT_TRUE(info.has_intensity);
  EXPECT_TRUE(info.has_ring);
  EXPECT_EQ(info.time_field, l.time.name);
  EXPECT_EQ(info.time_base_us, l.absolute_time ? 1700000000000000 : 0);
  ASSERT_EQ(cloud.num_points, 38);
  ASSERT_EQ(cloud.x.size(), 38u);
  ASSERT_EQ(cloud.time_offset_us.size(), 38u);
  for (size_t i = 0; i < expected.size(); ++i) {
    const auto& e = expected[i];
    EXPECT_EQ(cloud.x[i], static_cast<float>(e[0])) << i;
    EXPECT_EQ(cloud.y[i], static_cast<float>(e[1])) << i;
    EXPECT_EQ(cloud.z[i], static_cast<float>(e[2])) << i;
    EXPECT_EQ(cloud.intensity[i], static_cast<float>(e[3])) << i;
    EXPECT_EQ(cloud.ring[i], static_cast<int16_t>(e[4])) << i;
    // Absolute float64 seconds near 1.7e9 carry 0.24 us of resolution.
    EXPECT_NEAR(cloud.time_offset_us[i], e[5], l.absolute_time ? 1.0 : 0.0) << i;
  }
}

INSTANTIATE_TEST_SUITE_P(Encodings, PcdRoundTrip,
                         ::testing::Values(Layout{"ascii",
                                                  "ascii",
                                                  {"x", 'F', 4, 1},
                                                  {"intensity", 'F', 4, 1},
                                                  {"ring", 'U', 2, 1},
                                                  {"time", 'F', 4, 1}},
                                           Layout{"binary",
                                                  "binary",
                                                  {"x", 'F', 8, 1},
                                                  {"intensity", 'U', 1, 1},
                                                  {"ring", 'U', 1, 1},
                                                  {"t", 'U', 4, 1}},
                                           Layout{"binary_compressed",
                                                  "binary_compressed",
                                                  {"x", 'F', 4, 1},
                                                  {"intensity", 'U', 2, 2},
                                                  {"ring", 'I', 2, 1},
                                                  {"timestamp", 'F', 8, 1},
                                                  true}),
                         [](const auto& p) { return p.param.name; });

TEST(PcdReaderTest, OnlyXyzAndVersion06) {
  PcdSpec s;
  s.version = "0.6";
  s.fields = {{"x", 'F', 4, 1}, {"y", 'F', 4, 1}, {"z", 'F', 4, 1}};
  s.rows = {{1, 2, 3}, {4, 5, 6}};
  s.width = 1;
  s.height = 2;  // organized, 2 rows of 1
  for (const char* data : {"ascii", "binary", "binary_compressed"}) {
    lidar_frame_t cloud;
    PcdInfo info;
    std::string error;
    ASSERT_TRUE(ParsePcd(WritePcd(s, data), "t.pcd", PcdReadOptions{}, &cloud, &info, &error))
        << error;
    EXPECT_EQ(info.version, "0.6");
    ASSERT_EQ(cloud.num_points, 2);
    EXPECT_EQ(cloud.z[1], 6.0f);
    EXPECT_EQ(cloud.ring[0], -1);  // no rings
    EXPECT_EQ(cloud.time_offset_us[1], 0);
    EXPECT_EQ(cloud.intensity[0], 0.0f);
    EXPECT_FALSE(info.has_ring);
  }
}

// fuzz_pcd: float64 coordinates beyond float's range became inf points. They are dropped like
// NaN ones, and an out-of-range intensity (carried, never used) becomes 0.
TEST(PcdReaderTest, Float64BeyondFloatRangeIsDroppedNotInf) {
  PcdSpec s;
  s.fields = {{"x", 'F', 8, 1}, {"y", 'F', 8, 1}, {"z", 'F', 8, 1}, {"intensity", 'F', 8, 1}};
  s.rows = {{1, 2, 3, 1e300}, {1e300, 2, 3, 4}, {4, -1e39, 6, 7}, {7, 8, 9, 10}};
  for (const char* data : {"ascii", "binary", "binary_compressed"}) {
    lidar_frame_t cloud;
    PcdInfo info;
    std::string error;
    ASSERT_TRUE(ParsePcd(WritePcd(s, data), "t.pcd", PcdReadOptions{}, &cloud, &info, &error))
        << error;
    ASSERT_EQ(cloud.num_points, 2) << data;
    EXPECT_EQ(info.nan_dropped, 2) << data;
    EXPECT_EQ(cloud.x[1], 7.0f);
    EXPECT_EQ(cloud.intensity[0], 0.0f);
    EXPECT_EQ(cloud.intensity[1], 10.0f);
  }
}

// A valid file of 3 points (x y z intensity, float32) in `data`.
std::string Valid(const std::string& data) {
  PcdSpec s;
  s.fields = {{"x", 'F', 4, 1}, {"y", 'F', 4, 1}, {"z", 'F', 4, 1}, {"intensity", 'F', 4, 1}};
  s.rows = {{1, 2, 3, 4}, {5, 6, 7, 8}, {9, 10, 11, 12}};
  return WritePcd(s, data);
}

std::string Replace(std::string s, const std::string& from, const std::string& to) {
  const size_t at = s.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at != std::string::npos) s.replace(at, from.size(), to);
  return s;
}

std::string ErrorOf(const std::string& bytes, int64_t max_points = 4000000) {
  lidar_frame_t cloud;
  PcdInfo info;
  std::string error;
  PcdReadOptions options;
  options.max_points = max_points;
  EXPECT_FALSE(ParsePcd(bytes, "bad.pcd", options, &cloud, &info, &error));
  EXPECT_EQ(error.rfind("bad.pcd: ", 0), 0u) << error;  // names the file first
  return error;
}

TEST(PcdReaderTest, MalformedHeadersNameTheLineAndProblem) {
  const std::string b = Valid("binary");
  EXPECT_NE(ErrorOf(b.substr(0, b.find("DATA"))).find("no DATA line"), std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "VERSION 0.7", "VERSION 0.9")).find("line 2: VERSION '0.9'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "SIZE 4 4 4 4", "SIZE 4 4 4")).find("line 4: SIZE has 3 entries"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "SIZE 4 4 4 4", "SIZE 2 4 4 4")).find("TYPE F and SIZE 2"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "TYPE F F F F", "TYPE F F X F")).find("TYPE of field 'z' is 'X'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "FIELDS x y z intensity", "FIELDS x y w intensity"))
                .find("field 'z' is missing"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "TYPE F F F F", "TYPE I F F F")).find("field 'x' has TYPE I"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "COUNT 1 1 1 1", "COUNT 1 2 1 1")).find("field 'y' has COUNT 2"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "POINTS 3", "POINTS 4")).find("WIDTH*HEIGHT (3 x 1) != POINTS (4)"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "WIDTH 3", "WIDTH -3")).find("WIDTH must be one integer"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "VIEWPOINT", "COLOUR 1\nVIEWPOINT"))
                .find("line 9: unknown header key 'COLOUR'"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(b, "DATA binary", "DATA zip")).find("DATA must be"), std::string::npos);
  EXPECT_NE(ErrorOf(b, 2).find("exceeds the limit of 2 points"), std::string::npos);
}

TEST(PcdReaderTest, MalformedDataIsRefused) {
  const std::string b = Valid("binary");
  EXPECT_NE(ErrorOf(b.substr(0, b.size() - 1)).find("binary data truncated: 47 bytes, expected 48"),
            std::string::npos);

  const std::string c = Valid("binary_compressed");
  const size_t data_at = c.find("DATA binary_compressed\n") + 23;
  auto with_sizes = [&](uint32_t compressed, uint32_t raw) {
    std::string s = c;
    std::memcpy(&s[data_at], &compressed, 4);
    std::memcpy(&s[data_at + 4], &raw, 4);
    return s;
  };
  uint32_t csize = 0;
  std::memcpy(&csize, &c[data_at], 4);
  EXPECT_NE(ErrorOf(with_sizes(csize, 40)).find("uncompressed size 40 does not match"),
            std::string::npos);
  EXPECT_NE(ErrorOf(with_sizes(csize + 100, 48)).find("exceeds the"), std::string::npos);
  EXPECT_NE(ErrorOf(c.substr(0, c.size() - 2)).find("exceeds the"), std::string::npos);
  EXPECT_NE(ErrorOf(c.substr(0, data_at + 5)).find("size header is missing"), std::string::npos);
  EXPECT_NE(ErrorOf(c + "z").find("size mismatch"), std::string::npos);
  std::string corrupt = c;
  // A back reference reaching before the start of the output: LZF refuses it.
  corrupt[data_at + 8] = static_cast<char>(0xE0);
  corrupt[data_at + 9] = static_cast<char>(0xFF);
  corrupt[data_at + 10] = static_cast<char>(0xFF);
  EXPECT_NE(ErrorOf(corrupt).find("LZF data is corrupt"), std::string::npos);

  const std::string a = Valid("ascii");
  EXPECT_NE(ErrorOf(Replace(a, "5 6 7 8", "5 6 7")).find("line 13: 3 values, expected 4"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(a, "5 6 7 8", "5 six 7 8"))
                .find("line 13: 'six' is not a number (field 'y')"),
            std::string::npos);
  EXPECT_NE(ErrorOf(Replace(a, "9 10 11 12\n", ""))
                .find("ascii data truncated: 2 points, POINTS "
                      "says 3"),
            std::string::npos);
  EXPECT_NE(ErrorOf(a + "1 1 1 1\n").find("line 15: more points than POINTS (3)"),
            std::string::npos);
}

TEST(PcdReaderTest, BytesAfterTheLastBinaryPointAreIgnoredAsPclDoes) {
  // MATLAB's pcwrite leaves bytes after the points: the points are read, the rest counted.
  lidar_frame_t cloud;
  PcdInfo info;
  std::string error;
  ASSERT_TRUE(
      ParsePcd(Valid("binary") + "xx", "padded.pcd", PcdReadOptions{}, &cloud, &info, &error))
      << error;
  EXPECT_EQ(cloud.num_points, 3);
  EXPECT_EQ(cloud.z[2], 11.0f);
  EXPECT_EQ(info.trailing_bytes, 2);
  ASSERT_TRUE(ParsePcd(Valid("binary"), "exact.pcd", PcdReadOptions{}, &cloud, &info, &error));
  EXPECT_EQ(info.trailing_bytes, 0);
}

TEST(PcdReaderTest, RingMinusOneMeansNoRing) {
  PcdSpec s;
  s.fields = {{"x", 'F', 4, 1}, {"y", 'F', 4, 1}, {"z", 'F', 4, 1}, {"ring", 'I', 2, 1}};
  s.rows = {{1, 2, 3, -1}, {5, 6, 7, 4}};
  lidar_frame_t cloud;
  PcdInfo info;
  std::string error;
  for (const char* data : {"ascii", "binary"}) {
    ASSERT_TRUE(ParsePcd(WritePcd(s, data), "rings.pcd", PcdReadOptions{}, &cloud, &info, &error))
        << data << ": " << error;
    ASSERT_EQ(cloud.num_points, 2);
    EXPECT_EQ(cloud.ring[0], -1);
    EXPECT_EQ(cloud.ring[1], 4);
  }
  s.rows[0][3] = -2;
  EXPECT_NE(ErrorOf(WritePcd(s, "binary")).find("ring -2"), std::string::npos);
}

TEST(PcdReaderTest, MissingFileIsNamed) {
  lidar_frame_t cloud;
  PcdInfo info;
  std::string error;
  EXPECT_FALSE(ReadPcdFile("/nonexistent/a.pcd", PcdReadOptions{}, &cloud, &info, &error));
  EXPECT_NE(error.find("/nonexistent/a.pcd"), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
