// LoadRecordedImage (calibd-calibrate --folder, calibd-import): PNG and JPEG only, each decoded by
// its own library; images are read from their bytes,
// and one that declares more pixels than a camera frame has is refused from its header, before
// decoding (fuzz_recorded_image found a 156-byte JPEG declaring 60928x8208 px, which OpenCV
// decoded into half a gigabyte).

#include <gtest/gtest.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <string>

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/recorded_folder.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

std::string Corpus(const std::string& name) {
  return std::string(CALIBD_SOURCE_DIR) + "/tests/fuzz/corpus/" + name;
}

TEST(RecordedImageTest, HugeDeclaredImagesAreRefusedBeforeDecoding) {
  testing::TempDir dir;
  RecordedEntry entry;
  camera_frame_t msg;
  std::string error;

  // A small real JPEG loads, as mono8 or kept as JPEG bytes.
  entry.path = dir.file("small.jpg");
  std::filesystem::copy_file(Corpus("jpeg/grey_16x12.jpg"), entry.path);
  ASSERT_TRUE(LoadRecordedImage(entry, "cam0", false, &msg, &error)) << error;
  EXPECT_EQ(msg.width, 16);
  EXPECT_EQ(msg.height, 12);
  EXPECT_EQ(msg.size, 16 * 12);

  // The fuzzer's JPEG: refused from its header, at once.
  entry.path = dir.file("huge.jpg");
  std::filesystem::copy_file(Corpus("recorded_image/timeout-500-megapixel-jpeg"), entry.path);
  const auto t0 = std::chrono::steady_clock::now();
  for (const bool keep_jpeg : {false, true}) {
    EXPECT_FALSE(LoadRecordedImage(entry, "cam0", keep_jpeg, &msg, &error));
    EXPECT_NE(error.find("declares 60928x8208 px, more than a camera frame's 100 MP"),
              std::string::npos)
        << error;
  }
  EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::milliseconds(500));

  // A PNG header declaring 20000 x 20000 (the rest of the file missing).
  entry.path = dir.file("huge.png");
  {
    std::ofstream out(entry.path, std::ios::binary);
    const unsigned char png[] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1A, '\n', 0, 0, 0,    13,
                                 'I',  'H', 'D', 'R', 0,    0,    0x4E, 0x20, 0, 0, 0x4E, 0x20};
    out.write(reinterpret_cast<const char*>(png), sizeof(png));
  }
  EXPECT_FALSE(LoadRecordedImage(entry, "cam0", false, &msg, &error));
  EXPECT_NE(error.find("declares 20000x20000 px"), std::string::npos) << error;

  // Sides whose product overflows 64 bits (fuzz_recorded_image, UBSan): refused all the same.
  {
    std::ofstream out(entry.path, std::ios::binary | std::ios::trunc);
    const unsigned char png[] = {0x89, 'P',  'N',  'G',  '\r', '\n', 0x1A, '\n',
                                 0,    0,    0,    13,   'I',  'H',  'D',  'R',
                                 0xC7, 0xC7, 0xC7, 0xC7, 0xC7, 0xC7, 0xC7, 0xC7};
    out.write(reinterpret_cast<const char*>(png), sizeof(png));
  }
  EXPECT_FALSE(LoadRecordedImage(entry, "cam0", false, &msg, &error));
  EXPECT_NE(error.find("declares 3351758791x3351758791 px"), std::string::npos) << error;
}

TEST(RecordedImageTest, OnlyPngAndJpegAreDecodedEachByItsOwnLibrary) {
  testing::TempDir dir;
  RecordedEntry entry;
  camera_frame_t msg;
  std::string error;
  // A grey gradient as PNG: the same pixels back.
  cv::Mat grey(10, 20, CV_8UC1);
  for (int r = 0; r < grey.rows; ++r)
    for (int c = 0; c < grey.cols; ++c) grey.at<uint8_t>(r, c) = static_cast<uint8_t>(10 * c + r);
  entry.path = dir.file("grey.png");
  ASSERT_TRUE(cv::imwrite(entry.path, grey));
  ASSERT_TRUE(LoadRecordedImage(entry, "cam0", false, &msg, &error)) << error;
  ASSERT_EQ(msg.width, 20);
  ASSERT_EQ(msg.height, 10);
  EXPECT_EQ(msg.encoding, int{camera_frame_t::ENCODING_MONO8});
  for (int r = 0; r < grey.rows; ++r)
    for (int c = 0; c < grey.cols; ++c)
      ASSERT_EQ(msg.data[static_cast<size_t>(r * 20 + c)], grey.at<uint8_t>(r, c)) << r << "," << c;
  // A colour PNG comes out grey, near OpenCV's conversion (libpng weighs in linear light).
  cv::Mat colour(10, 20, CV_8UC3, cv::Scalar(40, 120, 200));
  entry.path = dir.file("colour.png");
  ASSERT_TRUE(cv::imwrite(entry.path, colour));
  ASSERT_TRUE(LoadRecordedImage(entry, "cam0", false, &msg, &error)) << error;
  const cv::Mat cv_grey = cv::imread(entry.path, cv::IMREAD_GRAYSCALE);
  EXPECT_NEAR(msg.data[0], cv_grey.at<uint8_t>(0, 0), 12);
  // A truncated PNG: libpng's message.
  std::string bytes, head;
  ASSERT_TRUE(ReadWholeFile(dir.file("grey.png"), &bytes, &error)) << error;
  entry.path = dir.file("cut.png");
  ASSERT_TRUE(WriteFileAtomic(entry.path, bytes.substr(0, 40), &error)) << error;
  EXPECT_FALSE(LoadRecordedImage(entry, "cam0", false, &msg, &error));
  EXPECT_NE(error.find("cut.png: cannot decode the PNG: "), std::string::npos) << error;
  // Bytes of any other format under a .png name (a DICOM preamble, a BMP): refused by name, no
  // other codec sees them.
  for (const std::string& other : {std::string(128, '\0') + "DICM" + std::string(1, '\x02'),
                                   std::string("BM") + std::string(60, '\x01')}) {
    entry.path = dir.file("other.png");
    ASSERT_TRUE(WriteFileAtomic(entry.path, other, &error)) << error;
    EXPECT_FALSE(LoadRecordedImage(entry, "cam0", false, &msg, &error));
    EXPECT_NE(error.find("other.png: not a PNG or a JPEG image"), std::string::npos) << error;
  }
}

}  // namespace
}  // namespace calibd
