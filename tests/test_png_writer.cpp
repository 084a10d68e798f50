// EncodePngRgb (drivers/png_writer.hpp): pictures encoded by libpng alone decode, through
// OpenCV's independent reader, to the same pixels; an empty picture is refused by name.

#include "calibd/drivers/png_writer.hpp"

#include <gtest/gtest.h>

#include <opencv2/imgcodecs.hpp>
#include <random>
#include <vector>

namespace calibd {
namespace {

TEST(PngWriterTest, APictureDecodesToItsPixels) {
  const int width = 37, height = 11;  // odd sizes: no row padding hides a stride error
  std::vector<uint8_t> rgb(static_cast<size_t>(width) * height * 3);
  std::mt19937 rng(3);
  for (auto& v : rgb) v = static_cast<uint8_t>(rng());
  std::string png, error;
  ASSERT_TRUE(EncodePngRgb(rgb.data(), width, height, &png, &error)) << error;
  const std::vector<uint8_t> bytes(png.begin(), png.end());
  const cv::Mat bgr = cv::imdecode(bytes, cv::IMREAD_COLOR);
  ASSERT_EQ(bgr.cols, width);
  ASSERT_EQ(bgr.rows, height);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      const uint8_t* p = &rgb[(static_cast<size_t>(y) * width + x) * 3];
      const cv::Vec3b q = bgr.at<cv::Vec3b>(y, x);
      ASSERT_EQ(q[2], p[0]) << x << "," << y;
      ASSERT_EQ(q[1], p[1]) << x << "," << y;
      ASSERT_EQ(q[0], p[2]) << x << "," << y;
    }
}

TEST(PngWriterTest, AnEmptyPictureIsRefused) {
  std::string png, error;
  const uint8_t pixel[3] = {1, 2, 3};
  EXPECT_FALSE(EncodePngRgb(pixel, 0, 1, &png, &error));
  EXPECT_EQ(error, "empty picture");
  EXPECT_FALSE(EncodePngRgb(nullptr, 1, 1, &png, &error));
}

}  // namespace
}  // namespace calibd
