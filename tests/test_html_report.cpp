// The HTML report writer (tools/calibrate/html_report): every section, escaping of every string,
// no network reference, base64 and SHA-256 against known vectors, and its speed on a demo-sized
// result. test_html_report_browser renders it in Chromium.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <string>

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/core/common/text_format.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "html_report.hpp"
#include "html_report_inputs.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

size_t Count(const std::string& text, const std::string& what) {
  size_t n = 0;
  for (size_t at = text.find(what); at != std::string::npos; at = text.find(what, at + 1)) ++n;
  return n;
}

std::string Lower(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(),
                 [](unsigned char c) { return static_cast<char>(std::tolower(c)); });
  return s;
}

TEST(HtmlReportTest, EverySectionIsPresent) {
  const tools::HtmlReportInput in = testing::AcceptedReportInput();
  const std::string html = tools::RenderHtmlReport(in);
  for (const char* id : {"verdict", "transform", "change", "quality", "thresholds", "per-board",
                         "per-distance", "overlays", "provenance"})
    EXPECT_EQ(Count(html, std::string("id=\"") + id + "\""), 1u) << id;
  EXPECT_NE(html.find("data-verdict=\"updated\""), std::string::npos);
  EXPECT_NE(html.find(">UPDATED<"), std::string::npos);
  EXPECT_NE(html.find("background:#1e8e3e"), std::string::npos);  // green banner
  EXPECT_NE(html.find(in.outcome.detail), std::string::npos);
  // Both directions, and the thresholds (gate of the reprojection error) with their values.
  EXPECT_NE(html.find("T_camera_lidar"), std::string::npos);
  EXPECT_NE(html.find("T_lidar_camera (inverse)"), std::string::npos);
  EXPECT_NE(html.find("quaternion x y z w"), std::string::npos);
  // The reprojection gate as configured (an angle) and in px at this camera.
  EXPECT_NE(html.find("0.140 deg ("), std::string::npos);
  const double angle_px = ReprojectionAnglePx(in.gates, ReprojectionFocalPx(in.camera));
  EXPECT_NE(html.find(FixedDecimal(angle_px, 2) + " px at the focal length"), std::string::npos);
  // Two plots: one bar per board (with its name) and one point per finite correspondence.
  EXPECT_EQ(Count(html, "<svg "), 2u);
  for (const auto& name : in.board_names) EXPECT_NE(html.find(name), std::string::npos);
  EXPECT_EQ(Count(html, "<circle "), in.reprojection.size() - 1);  // one NaN left out
  // Every picture, as its own PNG bytes in base64.
  EXPECT_EQ(Count(html, "src=\"data:image/png;base64,"), in.images.size());
  for (const auto& image : in.images)
    EXPECT_NE(html.find(tools::Base64(image.png.data(), image.png.size())), std::string::npos);
  // Provenance.
  EXPECT_NE(html.find(in.provenance.software_version), std::string::npos);
  EXPECT_NE(html.find(in.provenance.config_sha256), std::string::npos);
  EXPECT_NE(html.find(in.provenance.input_path), std::string::npos);
  EXPECT_NE(html.find("2023-11-14 22:13:20 UTC"), std::string::npos);
}

TEST(HtmlReportTest, RejectedResultIsRedWithItsReason) {
  tools::HtmlReportInput in = testing::RejectedReportInput();
  std::string html = tools::RenderHtmlReport(in);
  EXPECT_NE(html.find(">REJECTED<"), std::string::npos);
  EXPECT_NE(html.find("background:#c5221f"), std::string::npos);
  EXPECT_EQ(html.find("background:#1e8e3e"), std::string::npos);
  EXPECT_NE(html.find("<b>high_reprojection_error</b>: mean 9.40 px above 8.00 px"),
            std::string::npos);
  EXPECT_NE(html.find("class=\"fail\">fail<"), std::string::npos);
  // Rejected before the solve: no gate after it is judged, and the page says the transform is
  // not an estimate.
  in.outcome.solved = false;
  in.outcome.reason = Reason::kTooFewFrames;
  in.reprojection.clear();
  in.images.clear();
  html = tools::RenderHtmlReport(in);
  EXPECT_NE(html.find("Not solved"), std::string::npos);
  EXPECT_NE(html.find("not evaluated"), std::string::npos);
  EXPECT_NE(html.find("No reprojection errors to plot"), std::string::npos);
  EXPECT_NE(html.find("No overlay pictures"), std::string::npos);
}

// A figure the verdict judged within its sigma is not shown as failed beside an accepted result:
// a range offset beyond its 1.5 cm tolerance but measured too loosely to be refused for it, a
// principal point turn beyond 0.30 deg that the tags do not show beyond their sigma (the figures
// of a real VLP-16 session that the page once marked fail beside UPDATED). A figure the gates
// refuse is marked.
TEST(HtmlReportTest, RowsSayWhatTheVerdictDidWithTheirFigure) {
  tools::HtmlReportInput in = testing::AcceptedReportInput();
  QualityFigures& q = in.outcome.quality;
  q.lidar_range_offset_m = 0.0305;
  q.lidar_range_offset_sigma_m = 0.008;
  q.principal_point_fitted = true;
  q.principal_point_shift_px = {21.0, 0.0};
  q.principal_point_sigma_px = {10.0, 10.0};
  q.principal_point_systematic_px = {5.0, 5.0};
  q.principal_point_turn_deg = 0.37;
  q.principal_point_turn_sigma_deg = 0.24;
  std::string html = tools::RenderHtmlReport(in);
  EXPECT_EQ(Count(html, "class=\"fail\""), 0u) << html;
  EXPECT_NE(html.find("or within 4 sigma"), std::string::npos);
  // The stated 1 px, which tags at +-10 px cannot check that sharply, as the bound takes it.
  q.principal_point_stated_sigma_px = 1.0;
  html = tools::RenderHtmlReport(in);
  EXPECT_NE(html.find("within the stated +-1.0 px (taken as +-3.3 px"), std::string::npos);
  q.principal_point_sigma_px = {2.0, 2.0};
  html = tools::RenderHtmlReport(in);
  EXPECT_NE(html.find("within the stated +-1.0 px<"), std::string::npos);
  q.principal_point_sigma_px = {10.0, 10.0};
  q.lidar_range_offset_sigma_m = 0.002;  // measured: the gate refuses it
  html = tools::RenderHtmlReport(in);
  EXPECT_EQ(Count(html, "class=\"fail\""), 1u);
}

TEST(HtmlReportTest, EveryStringIsEscaped) {
  tools::HtmlReportInput in = testing::AcceptedReportInput();
  const std::string evil = "<script>alert('x')</script>\"&";
  in.camera_frame = evil;
  in.lidar_frame = evil;
  in.outcome.detail = evil;
  in.board_names[1] = evil;
  in.images[0].caption = evil;
  in.provenance.input_path = evil;
  in.provenance.config_path = evil;
  in.provenance.software_version = evil;
  in.provenance.method = evil;
  const std::string html = tools::RenderHtmlReport(in);
  EXPECT_EQ(Lower(html).find("<script"), std::string::npos);
  EXPECT_EQ(html.find(evil), std::string::npos);
  EXPECT_GE(Count(html, "&lt;script&gt;alert(&#39;x&#39;)&lt;/script&gt;&quot;&amp;"), 12u);
  EXPECT_EQ(tools::HtmlEscape("a<b>&\"c'"), "a&lt;b&gt;&amp;&quot;c&#39;");
}

TEST(HtmlReportTest, NoNetworkReference) {
  const std::string html = Lower(tools::RenderHtmlReport(testing::AcceptedReportInput()));
  for (const char* banned : {"http://", "https://", "src=\"//", "href=", "url(", "@import", "<link",
                             "<script", "<iframe", "<object", "<embed"})
    EXPECT_EQ(html.find(banned), std::string::npos) << banned;
  // Every src is a data: URI, and the page tells the browser to fetch nothing else.
  EXPECT_EQ(Count(html, "src=\""), Count(html, "src=\"data:image/png;base64,"));
  EXPECT_NE(html.find("content-security-policy\" content=\"default-src 'none'"), std::string::npos);
}

TEST(HtmlReportTest, Base64AndSha256MatchKnownVectors) {
  auto b64 = [](const std::string& s) {
    return tools::Base64(reinterpret_cast<const unsigned char*>(s.data()), s.size());
  };
  // RFC 4648 §10.
  EXPECT_EQ(b64(""), "");
  EXPECT_EQ(b64("f"), "Zg==");
  EXPECT_EQ(b64("fo"), "Zm8=");
  EXPECT_EQ(b64("foo"), "Zm9v");
  EXPECT_EQ(b64("foob"), "Zm9vYg==");
  EXPECT_EQ(b64("fooba"), "Zm9vYmE=");
  EXPECT_EQ(b64("foobar"), "Zm9vYmFy");
  const unsigned char high[] = {0xfb, 0xff, 0xfe};
  EXPECT_EQ(tools::Base64(high, 3), "+//+");
  // FIPS 180-2 appendix B.1.
  EXPECT_EQ(tools::Sha256Hex("abc"),
            "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad");
}

TEST(HtmlReportTest, WritesTheFile) {
  testing::TempDir dir;
  std::string error, text;
  const tools::HtmlReportInput in = testing::AcceptedReportInput();
  ASSERT_TRUE(tools::WriteHtmlReport(dir.file("report.html"), in, &error)) << error;
  ASSERT_TRUE(ReadWholeFile(dir.file("report.html"), &text, &error)) << error;
  EXPECT_EQ(text, tools::RenderHtmlReport(in));
  EXPECT_FALSE(tools::WriteHtmlReport(dir.file("missing/report.html"), in, &error));
  EXPECT_NE(error.find("missing/report.html"), std::string::npos) << error;
}

// Demo-sized: 600 correspondences and 4 overlay pictures of 1920x960 that PNG cannot compress
// (5.5 MB each, larger than the demo's). The budget is 200 ms in the optimised build.
TEST(HtmlReportTest, DemoSizedReportIsFast) {
  const tools::HtmlReportInput in = testing::AcceptedReportInput(true);
  double best_ms = 1e9;
  size_t size = 0;
  for (int run = 0; run < 3; ++run) {
    const auto t0 = std::chrono::steady_clock::now();
    size = tools::RenderHtmlReport(in).size();
    best_ms = std::min(best_ms, MsSince(t0));
  }
  std::cout << "demo-sized report: " << size / 1000 << " kB in " << best_ms << " ms\n";
  // The bound holds in an optimised build only: not under the sanitizers (GCC says so with
  // __SANITIZE_ADDRESS__, clang with __has_feature), where the same report took 210 ms.
#if defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CALIBD_TEST_UNDER_ASAN 1
#endif
#endif
#if defined(NDEBUG) && !defined(__SANITIZE_ADDRESS__) && !defined(CALIBD_TEST_UNDER_ASAN)
  EXPECT_LT(best_ms, 200.0);
#endif
}

}  // namespace
}  // namespace calibd
