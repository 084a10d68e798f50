// The HTML report in a real browser: Debian's headless Chromium renders an accepted and a rejected
// report; the screenshot must be rendered (not blank) with the verdict banner in its colour across
// the top, and the DOM Chromium built must carry the verdict. Chromium runs without a network
// (its own network namespace, when this process may create one): the page must need none.
// Chromium missing is a failure naming the package, not a skip.

#include <gtest/gtest.h>
#include <unistd.h>

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "calibd/drivers/atomic_file.hpp"
#include "html_report.hpp"
#include "html_report_inputs.hpp"
#include "run_command.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

constexpr int kWidth = 1200, kHeight = 1600;

// The browser, or empty.
std::string FindChromium() {
  for (const char* path : {"/usr/bin/chromium", "/usr/bin/chromium-browser"})
    if (::access(path, X_OK) == 0) return path;
  return "";
}

// `chromium --headless ...` with a private profile; without a network when `unshare -n` works.
std::string ChromiumCommand(const std::string& chromium, const testing::TempDir& dir,
                            const std::string& args) {
  static const bool offline = testing::RunCommand("unshare -n true >/dev/null 2>&1") == 0;
  return std::string(offline ? "unshare -n " : "") + chromium +
         " --headless --no-sandbox --disable-gpu --no-first-run --hide-scrollbars" +
         " --user-data-dir=" + dir.file("profile") + " " + args;
}

// Fraction of the pixels of `region` within `tolerance` (per channel) of `bgr`.
double ColourFraction(const cv::Mat& image, const cv::Rect& region, cv::Vec3b bgr, int tolerance) {
  int n = 0;
  for (int r = region.y; r < region.y + region.height; ++r)
    for (int c = region.x; c < region.x + region.width; ++c) {
      const cv::Vec3b p = image.at<cv::Vec3b>(r, c);
      if (std::abs(p[0] - bgr[0]) <= tolerance && std::abs(p[1] - bgr[1]) <= tolerance &&
          std::abs(p[2] - bgr[2]) <= tolerance)
        ++n;
    }
  return static_cast<double>(n) / region.area();
}

void CheckRendered(const tools::HtmlReportInput& in, const char* word, cv::Vec3b banner_bgr) {
  const std::string chromium = FindChromium();
  ASSERT_FALSE(chromium.empty())
      << "headless Chromium is needed to test the HTML report and is not installed: install "
         "Debian's 'chromium' package (deploy/install-deps.sh does)";
  testing::TempDir dir;
  std::string error;
  const std::string page = dir.file("report.html");
  ASSERT_TRUE(tools::WriteHtmlReport(page, in, &error)) << error;

  // The screenshot: rendered, with the banner's colour across the top.
  const std::string shot = dir.file("shot.png");
  ASSERT_EQ(testing::RunCommand(ChromiumCommand(
                chromium, dir,
                "--screenshot=" + shot + " --window-size=" + std::to_string(kWidth) + "," +
                    std::to_string(kHeight) + " file://" + page + " >" + dir.file("chromium.log") +
                    " 2>&1")),
            0)
      << "chromium failed; see its output in the test's directory";
  const cv::Mat image = cv::imread(shot, cv::IMREAD_COLOR);
  ASSERT_FALSE(image.empty()) << "no screenshot";
  ASSERT_EQ(image.cols, kWidth);
  ASSERT_EQ(image.rows, kHeight);
  // The banner is at least 140 px high across the whole width: its top 120 px, less the verdict
  // word's glyphs, are its colour; below it the page is mostly white.
  EXPECT_GT(ColourFraction(image, {0, 0, kWidth, 120}, banner_bgr, 12), 0.7) << word;
  EXPECT_GT(ColourFraction(image, {0, 200, kWidth, kHeight - 200}, {255, 255, 255}, 3), 0.5);
  // Not blank: text, tables and plots below the banner.
  cv::Mat grey;
  cv::cvtColor(image.rowRange(200, kHeight), grey, cv::COLOR_BGR2GRAY);
  EXPECT_GT(cv::countNonZero(grey < 128), 5000) << "nothing dark (text) below the banner";
  // The banner's white verdict word is drawn (white pixels inside the banner).
  EXPECT_GT(ColourFraction(image, {0, 0, kWidth, 120}, {255, 255, 255}, 30), 0.01);

  // The DOM Chromium built holds the verdict in the banner.
  const std::string dom = dir.file("dom.html");
  ASSERT_EQ(testing::RunCommand(ChromiumCommand(
                chromium, dir,
                "--dump-dom file://" + page + " >" + dom + " 2>" + dir.file("chromium-dom.log"))),
            0);
  std::string text;
  ASSERT_TRUE(ReadWholeFile(dom, &text, &error)) << error;
  EXPECT_NE(text.find(std::string("<p class=\"word\">") + word + "</p>"), std::string::npos)
      << text.substr(0, 2000);
  EXPECT_NE(text.find(in.outcome.detail), std::string::npos);
  // Parsed whole: the last section made it into the DOM.
  EXPECT_NE(text.find("id=\"provenance\""), std::string::npos);
}

TEST(HtmlReportBrowserTest, AcceptedReportRendersGreen) {
  CheckRendered(testing::AcceptedReportInput(), "UPDATED", {0x3e, 0x8e, 0x1e});
}

TEST(HtmlReportBrowserTest, RejectedReportRendersRed) {
  CheckRendered(testing::RejectedReportInput(), "REJECTED", {0x1f, 0x22, 0xc5});
}

}  // namespace
}  // namespace calibd
