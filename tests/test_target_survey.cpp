// TargetSurvey (calibd-calibrate --inspect): a checkerboard of a size nobody configured is found
// with its inner corners counted along the image's axes; an image without targets shows none.

#include <gtest/gtest.h>

#include <opencv2/imgproc.hpp>

#include "calibd/core/camera/target_survey.hpp"

namespace calibd {
namespace {

// A squares_x x squares_y checkerboard of `square_px` squares on a white page, slightly blurred.
cv::Mat Checkerboard(int squares_x, int squares_y, int square_px) {
  cv::Mat img(squares_y * square_px + 4 * square_px, squares_x * square_px + 4 * square_px, CV_8UC1,
              cv::Scalar(255));
  for (int r = 0; r < squares_y; ++r)
    for (int c = 0; c < squares_x; ++c)
      if ((r + c) % 2 == 0)
        cv::rectangle(img,
                      cv::Rect(2 * square_px + c * square_px, 2 * square_px + r * square_px,
                               square_px, square_px),
                      cv::Scalar(0), cv::FILLED);
  cv::GaussianBlur(img, img, cv::Size(3, 3), 0);
  return img;
}

ImageView View(const cv::Mat& m) {
  return ImageView{m.data, m.cols, m.rows, static_cast<int>(m.step[0])};
}

TEST(TargetSurveyTest, FindsACheckerboardOfAnySizeAlongTheImageAxes) {
  TargetSurvey survey;
  ASSERT_TRUE(survey.ok()) << survey.error();
  // 8 x 10 squares upright (7 x 9 inner corners), then the same board turned on its side.
  for (const auto& [sx, sy] : {std::pair{8, 10}, std::pair{10, 8}, std::pair{6, 9}}) {
    const cv::Mat img = Checkerboard(sx, sy, 40);
    CheckerSighting c;
    ASSERT_TRUE(survey.Checkerboard(View(img), &c)) << sx << " x " << sy;
    EXPECT_EQ(c.inner_cols, sx - 1);
    EXPECT_EQ(c.inner_rows, sy - 1);
    EXPECT_NEAR(c.square_px, 40.0, 1.0);
    EXPECT_NEAR(c.centre_px.x(), img.cols / 2.0, 3.0);
    EXPECT_NEAR(c.centre_px.y(), img.rows / 2.0, 3.0);
    EXPECT_TRUE(survey.Tags(View(img)).empty());
  }
}

TEST(TargetSurveyTest, AnEmptyImageShowsNothingAndAnUnknownFamilyIsNamed) {
  TargetSurvey survey;
  const cv::Mat grey(480, 640, CV_8UC1, cv::Scalar(128));
  CheckerSighting c;
  EXPECT_FALSE(survey.Checkerboard(View(grey), &c));
  EXPECT_TRUE(survey.Tags(View(grey)).empty());
  TargetSurveyConfig bad;
  bad.families = {"tag99h1"};
  TargetSurvey unknown(bad);
  EXPECT_FALSE(unknown.ok());
  EXPECT_NE(unknown.error().find("tag99h1"), std::string::npos);
}

}  // namespace
}  // namespace calibd
