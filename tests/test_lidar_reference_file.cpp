// The LiDAR reference cache's file (drivers/lidar_reference_file.hpp) on a real filesystem: a set
// comes back as written; a file cut short, of another layout or another machine, with sizes
// beyond any detector or one bit flipped is refused, naming what is wrong.

#include "calibd/drivers/lidar_reference_file.hpp"

#include <gtest/gtest.h>

#include <cstring>
#include <string>

#include "calibd/drivers/atomic_file.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

LidarReferenceSet SmallSet() {
  LidarReferenceSet set;
  set.key = 0x0123456789abcdefull;
  set.dims = 3;
  set.views = {0, 4, 7};
  set.descriptors = {0.5f, -0.25f, 0.125f, 1.0f, 2.0f, -3.0f, 0.0f, 1e-7f, -1e7f};
  return set;
}

std::string Refusal(const std::string& bytes) {
  LidarReferenceSet set;
  std::string error;
  EXPECT_FALSE(DecodeReferenceSet(bytes, &set, &error));
  return error;
}

TEST(LidarReferenceFileTest, ASetComesBackAsWrittenIntoANewDirectory) {
  const testing::TempDir dir;
  const std::string path = dir.file("cache/sub/lidar-references.bin");
  std::string error;
  ASSERT_TRUE(WriteReferenceFile(path, SmallSet(), &error)) << error;
  LidarReferenceSet back;
  ASSERT_TRUE(ReadReferenceFile(path, &back, &error)) << error;
  EXPECT_EQ(back.key, SmallSet().key);
  EXPECT_EQ(back.dims, 3);
  EXPECT_EQ(back.views, SmallSet().views);
  EXPECT_EQ(back.descriptors, SmallSet().descriptors);
  // The header (8 + 4 + 4 + 8 + 4 + 4), 3 views, 9 floats and the CRC-32.
  std::string bytes;
  ASSERT_TRUE(ReadWholeFile(path, &bytes, &error)) << error;
  EXPECT_EQ(bytes.size(), 32u + 3 * 4 + 9 * 4 + 4);
  EXPECT_EQ(bytes.substr(0, 8), "CALIBDLR");

  EXPECT_FALSE(ReadReferenceFile(dir.file("none.bin"), &back, &error));
  EXPECT_NE(error.find("none.bin"), std::string::npos) << error;
}

TEST(LidarReferenceFileTest, DamagedForeignOrImplausibleFilesAreRefusedWithTheReason) {
  const std::string good = EncodeReferenceSet(SmallSet());
  EXPECT_EQ(Refusal(""), "too short for a reference file (0 bytes)");
  EXPECT_EQ(Refusal("CALIBDLX" + good.substr(8)),
            "not a calibd reference file (no CALIBDLR magic)");
  std::string other = good;
  other[8] = 2;  // layout version 2
  EXPECT_EQ(Refusal(other), "layout version 2, this build reads 1");
  other = good;
  std::swap(other[12], other[15]);  // the byte-order mark as another machine writes it
  EXPECT_EQ(Refusal(other), "written on a machine of another byte order");
  EXPECT_EQ(Refusal(good.substr(0, 20)), "truncated header");
  EXPECT_EQ(Refusal(good.substr(0, good.size() - 1)),
            "51 bytes after the header, 52 expected for 3 views of 3 values");
  other = good;
  const int32_t huge = 1 << 30;
  std::memcpy(&other[28], &huge, sizeof(huge));  // the count
  EXPECT_EQ(Refusal(other), "implausible sizes: 1073741824 views of 3 values");
  for (size_t at : {size_t{16}, size_t{40}, good.size() - 10, good.size() - 1}) {
    other = good;
    other[at] = static_cast<char>(other[at] ^ 0x01);
    EXPECT_EQ(Refusal(other), "CRC-32 mismatch (a damaged file)") << "bit flipped at " << at;
  }
}

}  // namespace
}  // namespace calibd
