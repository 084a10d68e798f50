// CameraFrameToView (drivers/src/lcm_frames.cpp) on JPEG and bgr8 frames: libjpeg-turbo decodes
// JPEG to grey exactly as OpenCV's imgcodecs does (the reference here; the agent no longer links
// it), into the caller's image without allocating, and refuses damaged data and lying sizes with
// a message that names the problem.

#include <gtest/gtest.h>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>

#include "calibd/drivers/lcm_frames.hpp"
#include "counting_new.hpp"

namespace calibd {
namespace {

// A test picture with edges, gradients and noise (what JPEG finds hard), fixed by the seed.
cv::Mat Picture(int width, int height, int channels, uint64_t seed) {
  cv::Mat image(height, width, CV_8UC(channels));
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, 40);
  for (int y = 0; y < height; ++y)
    for (int x = 0; x < width; ++x) {
      uint8_t* p = image.ptr<uint8_t>(y) + x * channels;
      const bool square = ((x / 16) + (y / 16)) % 2 == 0;
      for (int c = 0; c < channels; ++c)
        p[c] = cv::saturate_cast<uint8_t>(p[c] + (square ? 180 : 20) + (x + 2 * y + 50 * c) % 60);
    }
  return image;
}

std::vector<uint8_t> Jpeg(const cv::Mat& image, int quality = 90) {
  std::vector<uint8_t> bytes;
  EXPECT_TRUE(cv::imencode(".jpg", image, bytes, {cv::IMWRITE_JPEG_QUALITY, quality}));
  return bytes;
}

camera_frame_t JpegMessage(const std::vector<uint8_t>& bytes, int width, int height) {
  camera_frame_t m;
  m.utime = 1;
  m.camera_id = "front";
  m.width = width;
  m.height = height;
  m.stride = 0;
  m.encoding = camera_frame_t::ENCODING_JPEG;
  m.size = static_cast<int32_t>(bytes.size());
  m.data = bytes;
  return m;
}

cv::Mat ViewMat(const ImageView& v) {
  return cv::Mat(v.height, v.width, CV_8UC1, const_cast<uint8_t*>(v.data),
                 static_cast<size_t>(v.stride));
}

double MaxDifference(const cv::Mat& a, const cv::Mat& b) {
  double max = 0;
  cv::minMaxLoc(cv::abs(a - b), nullptr, &max);
  return max;
}

// Decodes `m`, expecting success: the view as an image (a copy).
cv::Mat Decode(const camera_frame_t& m, cv::Mat* decoded) {
  ImageView view;
  std::string error;
  EXPECT_TRUE(CameraFrameToView(m, FrameLimits{}, decoded, &view, &error)) << error;
  if (view.data == nullptr) return cv::Mat();
  EXPECT_EQ(view.width, m.width);
  EXPECT_EQ(view.height, m.height);
  return ViewMat(view).clone();
}

// Decodes `m`, expecting a refusal: the message.
std::string Refusal(const camera_frame_t& m, const FrameLimits& limits = FrameLimits{}) {
  cv::Mat decoded;
  ImageView view;
  std::string error;
  EXPECT_FALSE(CameraFrameToView(m, limits, &decoded, &view, &error));
  return error;
}

TEST(LcmFramesJpeg, GreyDecodesToOpenCvsPixels) {
  const cv::Mat grey = Picture(640, 480, 1, 1);
  const std::vector<uint8_t> bytes = Jpeg(grey);
  cv::Mat decoded;
  const cv::Mat ours = Decode(JpegMessage(bytes, 640, 480), &decoded);
  ASSERT_FALSE(ours.empty());
  const cv::Mat reference = cv::imdecode(bytes, cv::IMREAD_GRAYSCALE);
  // Both are libjpeg-turbo with its default (islow) DCT: the same pixels, not just close ones.
  EXPECT_EQ(MaxDifference(ours, reference), 0);
  // And close to the picture itself (quality 90 on noise and sharp edges).
  EXPECT_LT(cv::norm(ours, grey, cv::NORM_L1) / static_cast<double>(grey.total()), 4.0);
}

TEST(LcmFramesJpeg, ColourDecodesToGrey) {
  const cv::Mat bgr = Picture(320, 240, 3, 2);
  for (int quality : {50, 95}) {
    const std::vector<uint8_t> bytes = Jpeg(bgr, quality);  // YCbCr, chroma subsampled 4:2:0
    cv::Mat decoded;
    const cv::Mat ours = Decode(JpegMessage(bytes, 320, 240), &decoded);
    ASSERT_EQ(ours.type(), CV_8UC1);
    EXPECT_EQ(MaxDifference(ours, cv::imdecode(bytes, cv::IMREAD_GRAYSCALE)), 0) << quality;
    cv::Mat grey;
    cv::cvtColor(bgr, grey, cv::COLOR_BGR2GRAY);
    EXPECT_LT(cv::norm(ours, grey, cv::NORM_L1) / static_cast<double>(grey.total()), 8.0);
  }
}

TEST(LcmFramesJpeg, ProgressiveDecodes) {
  const cv::Mat grey = Picture(200, 120, 1, 3);
  std::vector<uint8_t> bytes;
  ASSERT_TRUE(cv::imencode(".jpg", grey, bytes, {cv::IMWRITE_JPEG_PROGRESSIVE, 1}));
  cv::Mat decoded;
  EXPECT_EQ(MaxDifference(Decode(JpegMessage(bytes, 200, 120), &decoded),
                          cv::imdecode(bytes, cv::IMREAD_GRAYSCALE)),
            0);
}

TEST(LcmFramesJpeg, DecodesIntoTheCallersLargerImage) {
  // The agent's intake allocates its image once at the limits: frames go into its corner.
  cv::Mat decoded(600, 800, CV_8UC1, cv::Scalar(7));
  const uint8_t* const buffer = decoded.data;
  const cv::Mat grey = Picture(640, 480, 1, 4);
  const std::vector<uint8_t> bytes = Jpeg(grey);
  ImageView view;
  std::string error;
  ASSERT_TRUE(
      CameraFrameToView(JpegMessage(bytes, 640, 480), FrameLimits{}, &decoded, &view, &error))
      << error;
  EXPECT_EQ(decoded.data, buffer);
  EXPECT_EQ(decoded.cols, 800);
  EXPECT_EQ(view.data, buffer);
  EXPECT_EQ(view.stride, 800);
  EXPECT_EQ(MaxDifference(ViewMat(view), cv::imdecode(bytes, cv::IMREAD_GRAYSCALE)), 0);
  EXPECT_EQ(decoded.at<uint8_t>(0, 640), 7) << "beyond the frame's width: untouched";
  EXPECT_EQ(decoded.at<uint8_t>(480, 0), 7) << "below the frame: untouched";

  // bgr8 the same way.
  const cv::Mat bgr = Picture(320, 200, 3, 5);
  camera_frame_t m;
  m.width = 320;
  m.height = 200;
  m.stride = 3 * 320;
  m.encoding = camera_frame_t::ENCODING_BGR8;
  m.data.assign(bgr.data, bgr.data + bgr.total() * 3);
  m.size = static_cast<int32_t>(m.data.size());
  ASSERT_TRUE(CameraFrameToView(m, FrameLimits{}, &decoded, &view, &error)) << error;
  EXPECT_EQ(view.data, buffer);
  cv::Mat grey_bgr;
  cv::cvtColor(bgr, grey_bgr, cv::COLOR_BGR2GRAY);
  EXPECT_EQ(MaxDifference(ViewMat(view), grey_bgr), 0);

  // A smaller image than the frame is reallocated at the frame's size.
  cv::Mat small(10, 10, CV_8UC1);
  ASSERT_TRUE(CameraFrameToView(JpegMessage(bytes, 640, 480), FrameLimits{}, &small, &view, &error))
      << error;
  EXPECT_EQ(small.cols, 640);
  EXPECT_EQ(small.rows, 480);
  EXPECT_EQ(view.stride, 640);
}

TEST(LcmFramesJpeg, NoOperatorNewPerFrame) {
  const cv::Mat grey = Picture(640, 480, 1, 6);
  const camera_frame_t m = JpegMessage(Jpeg(grey), 640, 480);
  const camera_frame_t colour = JpegMessage(Jpeg(Picture(640, 480, 3, 7)), 640, 480);
  cv::Mat decoded(480, 640, CV_8UC1);
  ImageView view;
  std::string error;
  error.reserve(256);
  ASSERT_TRUE(CameraFrameToView(m, FrameLimits{}, &decoded, &view, &error)) << error;  // warm-up
  const long before = calibd::testing::Allocations();  // this test starts no thread
  bool ok = true;
  for (int i = 0; i < 20; ++i) {
    ok = CameraFrameToView(m, FrameLimits{}, &decoded, &view, &error) && ok;
    ok = CameraFrameToView(colour, FrameLimits{}, &decoded, &view, &error) && ok;
  }
  const long news = calibd::testing::Allocations() - before;
  EXPECT_TRUE(ok) << error;
  EXPECT_EQ(news, 0) << "operator new calls in 40 JPEG decodes";
}

TEST(LcmFramesJpeg, TruncatedIsRefused) {
  const std::vector<uint8_t> bytes = Jpeg(Picture(640, 480, 1, 8));
  // Cut in the middle of the scan (libjpeg alone would fill the rest with grey) and in the
  // header.
  for (size_t keep : {bytes.size() / 2, bytes.size() - 2, size_t{100}, size_t{3}}) {
    const std::vector<uint8_t> cut(bytes.begin(), bytes.begin() + static_cast<long>(keep));
    const std::string error = Refusal(JpegMessage(cut, 640, 480));
    EXPECT_NE(error.find("Premature end of JPEG file"), std::string::npos) << keep << ": " << error;
  }
  // The decoder is fine afterwards.
  cv::Mat decoded;
  EXPECT_FALSE(Decode(JpegMessage(bytes, 640, 480), &decoded).empty());
}

TEST(LcmFramesJpeg, CorruptIsRefused) {
  const std::vector<uint8_t> bytes = Jpeg(Picture(640, 480, 1, 9));
  // Not a JPEG at all.
  std::vector<uint8_t> png;
  ASSERT_TRUE(cv::imencode(".png", Picture(64, 48, 1, 9), png));
  EXPECT_NE(Refusal(JpegMessage(png, 64, 48)).find("Not a JPEG file"), std::string::npos);
  // A marker in the middle of the entropy-coded data (where the scan is read as corrupt).
  std::vector<uint8_t> marker = bytes;
  marker[marker.size() / 2] = 0xFF;
  marker[marker.size() / 2 + 1] = 0xD3;  // RST3, without a restart interval
  std::string error = Refusal(JpegMessage(marker, 640, 480));
  EXPECT_NE(error.find("JPEG data is damaged"), std::string::npos) << error;
  // A header whose quantisation table segment lies about its length.
  std::vector<uint8_t> header = bytes;
  for (size_t i = 2; i + 3 < header.size(); ++i)
    if (header[i] == 0xFF && header[i + 1] == 0xDB) {  // DQT
      header[i + 2] = 0x00;
      header[i + 3] = 0x05;
      break;
    }
  error = Refusal(JpegMessage(header, 640, 480));
  EXPECT_NE(error.find("JPEG header does not decode"), std::string::npos) << error;
  cv::Mat decoded;
  EXPECT_FALSE(Decode(JpegMessage(bytes, 640, 480), &decoded).empty());
}

TEST(LcmFramesJpeg, SizeOtherThanTheMessagesIsRefused) {
  const std::vector<uint8_t> bytes = Jpeg(Picture(64, 48, 1, 10));
  EXPECT_EQ(Refusal(JpegMessage(bytes, 64, 47)),
            "camera_frame_t: JPEG is 64x48, header says 64x47");
  EXPECT_EQ(Refusal(JpegMessage(bytes, 48, 64)),
            "camera_frame_t: JPEG is 64x48, header says 48x64");
  // Beyond the limits: the message's own size first, then the JPEG's.
  FrameLimits limits;
  limits.max_width = 32;
  EXPECT_EQ(Refusal(JpegMessage(bytes, 64, 48), limits),
            "camera_frame_t: width/height 64x48 out of range");
  EXPECT_EQ(Refusal(JpegMessage(bytes, 32, 48), limits),
            "camera_frame_t: JPEG is 64x48, beyond the limits 32x16384");
  // Empty.
  EXPECT_EQ(Refusal(JpegMessage({}, 64, 48)), "camera_frame_t: empty JPEG data");
}

}  // namespace
}  // namespace calibd
