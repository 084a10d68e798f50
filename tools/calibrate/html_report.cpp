#include "html_report.hpp"

#include <openssl/evp.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <ctime>
#include <limits>
#include <map>

#include "calibd/core/verdict/principal_point_check.hpp"
#include "calibd/core/verdict/verdict.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/calibration_export.hpp"

namespace calibd::tools {
namespace {

constexpr const char* kGreen = "#1e8e3e";  // verified, updated: the banner and passed gates
constexpr const char* kRed = "#c5221f";    // rejected, failed gates
// Board colours in the plots (Okabe-Ito, distinguishable with colour-blindness).
constexpr const char* kPalette[] = {"#0072b2", "#e69f00", "#009e73", "#cc79a7",
                                    "#56b4e9", "#d55e00", "#f0e442", "#000000"};
constexpr int kPaletteSize = static_cast<int>(sizeof(kPalette) / sizeof(kPalette[0]));

// Fixed-point number; "n/a" for NaN, "inf" for infinities (formal sigmas of a singular problem).
std::string Num(double v, int precision) {
  if (std::isnan(v)) return "n/a";
  if (std::isinf(v)) return v > 0 ? "inf" : "-inf";
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.*f", precision, v);
  return buf;
}

// Where the bound takes the stated principal point sigma wider than stated, because the tags
// could not check it that sharply (StatedSigmaAsChecked); empty where it takes it as stated.
std::string StatedAsCheckedText(const QualityFigures& q) {
  const double taken =
      StatedSigmaWidened(q.principal_point_stated_sigma_px, q.principal_point_sigma_px);
  if (!(taken > 0.0)) return "";
  return " (taken as +-" + Num(taken, 1) + " px: the tags could not check it sharper)";
}

// Scientific notation for figures spanning decades (plane conditioning, eigenvalues).
std::string Sci(double v) {
  if (!std::isfinite(v)) return Num(v, 0);
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%.3g", v);
  return buf;
}

std::string UtcTime(int64_t unix_s) {
  const std::time_t t = static_cast<std::time_t>(unix_s);
  std::tm tm{};
  if (gmtime_r(&t, &tm) == nullptr) return "unknown";
  char buf[64];
  std::strftime(buf, sizeof(buf), "%Y-%m-%d %H:%M:%S UTC", &tm);
  return buf;
}

const char* kStyle = R"(
body{margin:0;font-family:sans-serif;color:#202124;background:#fff}
main{padding:0 24px 24px 24px;max-width:1400px}
h2{border-bottom:1px solid #dadce0;padding-bottom:4px;margin-top:28px}
#verdict{padding:28px 24px;color:#fff;min-height:140px;box-sizing:border-box}
#verdict .word{font-size:64px;font-weight:bold;letter-spacing:2px;margin:0}
#verdict .reason{font-size:22px;margin:8px 0 0 0}
table{border-collapse:collapse;margin:8px 0}
td,th{border:1px solid #dadce0;padding:4px 10px;text-align:left;vertical-align:top}
th{background:#f1f3f4}
td.num{text-align:right;font-family:monospace}
table.matrix td{font-family:monospace;text-align:right;border:none;padding:2px 10px}
.pass{color:#1e8e3e;font-weight:bold}
.fail{color:#c5221f;font-weight:bold}
.na{color:#80868b}
.note{color:#5f6368}
.blocks{display:flex;flex-wrap:wrap;gap:32px}
figure{margin:8px 0 24px 0}
figure img{max-width:100%;height:auto;border:1px solid #dadce0}
svg{background:#fff;border:1px solid #dadce0}
svg text{font-family:sans-serif;font-size:12px;fill:#202124}
)";

// A step of 1, 2 or 5 times a power of ten giving about `ticks` intervals over [0, top].
double NiceStep(double top, int ticks) {
  if (!(top > 0.0)) return 1.0;
  const double raw = top / ticks;
  const double p = std::pow(10.0, std::floor(std::log10(raw)));
  for (double m : {1.0, 2.0, 5.0})
    if (m * p >= raw) return m * p;
  return 10.0 * p;
}

int Decimals(double step) {
  return step >= 1.0 ? 0 : static_cast<int>(std::ceil(-std::log10(step)));
}

// A plot frame: data [x0, x1] x [0, y1] into the SVG box inside the margins.
struct PlotFrame {
  double width = 760, height = 320;
  double left = 60, right = 20, top = 20, bottom = 50;
  double x0 = 0, x1 = 1, y1 = 1;
  double X(double x) const { return left + (x - x0) / (x1 - x0) * (width - left - right); }
  double Y(double y) const { return height - bottom - y / y1 * (height - top - bottom); }
};

// Y axis with grid lines and ticks, its label, and the x axis line.
void YAxis(const PlotFrame& f, double step, const std::string& label, std::string* s) {
  const int decimals = Decimals(step);
  for (double y = 0.0; y <= f.y1 + 1e-9; y += step) {
    char buf[256];
    std::snprintf(buf, sizeof(buf),
                  "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#e8eaed\"/>"
                  "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\">%.*f</text>",
                  f.left, f.Y(y), f.width - f.right, f.Y(y), f.left - 6, f.Y(y) + 4, decimals, y);
    *s += buf;
  }
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"#5f6368\"/>"
                "<text x=\"14\" y=\"%.1f\" transform=\"rotate(-90 14 %.1f)\" "
                "text-anchor=\"middle\">",
                f.left, f.Y(0.0), f.width - f.right, f.Y(0.0), f.height / 2, f.height / 2);
  *s += buf;
  *s += HtmlEscape(label) + "</text>";
}

// Dashed horizontal line at the gate, labelled.
void GateLine(const PlotFrame& f, double gate, std::string* s) {
  if (!(gate > 0.0) || gate > f.y1) return;
  char buf[320];
  std::snprintf(buf, sizeof(buf),
                "<line x1=\"%.1f\" y1=\"%.1f\" x2=\"%.1f\" y2=\"%.1f\" stroke=\"%s\" "
                "stroke-dasharray=\"6 4\"/><text x=\"%.1f\" y=\"%.1f\" text-anchor=\"end\" "
                "style=\"fill:%s\">gate %.2f px</text>",
                f.left, f.Y(gate), f.width - f.right, f.Y(gate), kRed, f.width - f.right - 4,
                f.Y(gate) - 4, kRed, gate);
  *s += buf;
}

double Mean(const std::vector<double>& v) {
  double sum = 0.0;
  for (double x : v) sum += x;
  return v.empty() ? std::numeric_limits<double>::quiet_NaN() : sum / static_cast<double>(v.size());
}

// Bar chart: mean reprojection error of each configured board over its correspondences.
// The reprojection gate the verdict applied (raised for a sparse LiDAR); the configured one
// where the session stopped before the quality figures.
double ReprojectionGate(const HtmlReportInput& in) {
  const double gate = in.outcome.quality.reprojection_gate_px;
  return gate > 0.0 ? gate : ReprojectionAnglePx(in.gates, ReprojectionFocalPx(in.camera));
}

std::string PerBoardPlot(const HtmlReportInput& in) {
  const size_t boards = in.board_names.size();
  std::vector<std::vector<double>> errors(boards);
  for (const auto& r : in.reprojection)
    if (r.board_index >= 0 && static_cast<size_t>(r.board_index) < boards &&
        std::isfinite(r.mean_px))
      errors[static_cast<size_t>(r.board_index)].push_back(r.mean_px);
  if (boards == 0) return "<p class=\"na\">No boards configured.</p>";
  double top = ReprojectionGate(in) * 1.15;
  for (const auto& e : errors)
    if (!e.empty()) top = std::max(top, Mean(e) * 1.15);
  PlotFrame f;
  f.x0 = 0.0;
  f.x1 = static_cast<double>(boards);
  const double step = NiceStep(top, 5);
  f.y1 = std::ceil(top / step) * step;
  std::string s = "<svg width=\"760\" height=\"320\" ";
  s += "viewBox=\"0 0 760 320\" role=\"img\" aria-label=\"mean reprojection error per board\">";
  YAxis(f, step, "mean reprojection error [px]", &s);
  const double slot = f.X(1.0) - f.X(0.0);
  for (size_t b = 0; b < boards; ++b) {
    const double x = f.X(static_cast<double>(b)) + slot * 0.2;
    const double w = slot * 0.6;
    char buf[512];
    if (!errors[b].empty()) {
      const double m = Mean(errors[b]);
      std::snprintf(buf, sizeof(buf),
                    "<rect x=\"%.1f\" y=\"%.1f\" width=\"%.1f\" height=\"%.1f\" fill=\"%s\"/>"
                    "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%.2f px (n=%zu)</text>",
                    x, f.Y(m), w, f.Y(0.0) - f.Y(m), kPalette[b % kPaletteSize], x + w / 2,
                    f.Y(m) - 5, m, errors[b].size());
    } else {
      std::snprintf(buf, sizeof(buf),
                    "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\" style=\"fill:#80868b\">"
                    "no correspondence</text>",
                    x + w / 2, f.Y(0.0) - 6);
    }
    s += buf;
    std::snprintf(buf, sizeof(buf), "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">",
                  x + w / 2, f.Y(0.0) + 18);
    s += buf;
    s += HtmlEscape(in.board_names[b]) + "</text>";
  }
  GateLine(f, ReprojectionGate(in), &s);
  s += "</svg>";
  return s;
}

// Scatter of every correspondence's error against its distance (coloured by board), with the
// mean of each distance bin as a line.
std::string DistancePlot(const HtmlReportInput& in) {
  double d_min = std::numeric_limits<double>::infinity(), d_max = 0.0, e_max = 0.0;
  size_t finite = 0;
  for (const auto& r : in.reprojection) {
    if (!std::isfinite(r.mean_px) || !std::isfinite(r.distance_m)) continue;
    d_min = std::min(d_min, r.distance_m);
    d_max = std::max(d_max, r.distance_m);
    e_max = std::max(e_max, r.mean_px);
    ++finite;
  }
  if (finite == 0) return "<p class=\"na\">No reprojection errors to plot.</p>";
  PlotFrame f;
  const double x_step = NiceStep(std::max(d_max - d_min, 1.0), 8);
  f.x0 = std::floor(d_min / x_step) * x_step;
  f.x1 = std::max(f.x0 + x_step, std::ceil(d_max / x_step) * x_step);
  const double top = std::max(e_max, ReprojectionGate(in)) * 1.1;
  const double step = NiceStep(top, 5);
  f.y1 = std::ceil(top / step) * step;
  std::string s = "<svg width=\"760\" height=\"320\" ";
  s += "viewBox=\"0 0 760 320\" role=\"img\" aria-label=\"reprojection error against distance\">";
  YAxis(f, step, "reprojection error [px]", &s);
  char buf[256];
  for (double x = f.x0; x <= f.x1 + 1e-9; x += x_step) {
    std::snprintf(buf, sizeof(buf),
                  "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">%.*f</text>", f.X(x),
                  f.Y(0.0) + 18, Decimals(x_step), x);
    s += buf;
  }
  std::snprintf(buf, sizeof(buf),
                "<text x=\"%.1f\" y=\"%.1f\" text-anchor=\"middle\">camera to board distance "
                "[m]</text>",
                (f.left + f.width - f.right) / 2, f.height - 8);
  s += buf;
  // Bins of one x tick: their mean error as a line over the points.
  const int bins = std::max(1, static_cast<int>(std::lround((f.x1 - f.x0) / x_step)));
  std::vector<double> bin_sum(static_cast<size_t>(bins), 0.0);
  std::vector<int> bin_n(static_cast<size_t>(bins), 0);
  for (const auto& r : in.reprojection) {
    if (!std::isfinite(r.mean_px) || !std::isfinite(r.distance_m)) continue;
    const int pick = r.board_index >= 0 ? r.board_index % kPaletteSize : kPaletteSize - 1;
    std::snprintf(buf, sizeof(buf),
                  "<circle cx=\"%.1f\" cy=\"%.1f\" r=\"2.5\" fill=\"%s\" fill-opacity=\"0.6\"/>",
                  f.X(r.distance_m), f.Y(r.mean_px), kPalette[pick]);
    s += buf;
    const int b = std::clamp(static_cast<int>((r.distance_m - f.x0) / x_step), 0, bins - 1);
    bin_sum[static_cast<size_t>(b)] += r.mean_px;
    ++bin_n[static_cast<size_t>(b)];
  }
  std::string line;
  for (int b = 0; b < bins; ++b) {
    if (bin_n[static_cast<size_t>(b)] == 0) continue;
    const double m = bin_sum[static_cast<size_t>(b)] / bin_n[static_cast<size_t>(b)];
    const double x = f.X(f.x0 + (b + 0.5) * x_step);
    std::snprintf(buf, sizeof(buf), "%s%.1f,%.1f", line.empty() ? "" : " ", x, f.Y(m));
    line += buf;
    std::snprintf(buf, sizeof(buf),
                  "<rect x=\"%.1f\" y=\"%.1f\" width=\"7\" height=\"7\" fill=\"#202124\"/>",
                  x - 3.5, f.Y(m) - 3.5);
    s += buf;
  }
  s += "<polyline fill=\"none\" stroke=\"#202124\" stroke-width=\"2\" points=\"" + line + "\"/>";
  GateLine(f, ReprojectionGate(in), &s);
  s += "</svg>";
  return s;
}

std::string MatrixTable(const Pose& T) {
  std::string s = "<table class=\"matrix\">";
  for (int r = 0; r < 4; ++r) {
    s += "<tr>";
    for (int c = 0; c < 4; ++c) s += "<td>" + Num(T.matrix()(r, c), 9) + "</td>";
    s += "</tr>";
  }
  return s + "</table>";
}

// One transform: 4x4, xyz, rpy (RpyFromRotation's convention), quaternion xyzw (w >= 0).
std::string TransformBlock(const std::string& title, const Pose& T) {
  const Eigen::Vector3d t = T.translation();
  const Eigen::Vector3d rpy = RpyFromRotation(T.linear()) * kRad2Deg;
  const Eigen::Vector4d q = QuaternionXyzw(T.linear());
  std::string s = "<div><h3>" + HtmlEscape(title) + "</h3>" + MatrixTable(T) + "<table>";
  s += "<tr><th>xyz [m]</th><td class=\"num\">" + Num(t.x(), 6) + " " + Num(t.y(), 6) + " " +
       Num(t.z(), 6) + "</td></tr>";
  s += "<tr><th>roll pitch yaw [deg]</th><td class=\"num\">" + Num(rpy.x(), 5) + " " +
       Num(rpy.y(), 5) + " " + Num(rpy.z(), 5) + "</td></tr>";
  s += "<tr><th>quaternion x y z w</th><td class=\"num\">" + Num(q(0), 9) + " " + Num(q(1), 9) +
       " " + Num(q(2), 9) + " " + Num(q(3), 9) + "</td></tr>";
  return s + "</table></div>";
}

enum class Gate { kPass, kFail, kNotReached, kNone };

std::string GateCell(Gate g) {
  switch (g) {
    case Gate::kPass:
      return "<td class=\"pass\">pass</td>";
    case Gate::kFail:
      return "<td class=\"fail\">fail</td>";
    case Gate::kNone:
      return "<td class=\"na\">figure only</td>";
    case Gate::kNotReached:
      break;
  }
  return "<td class=\"na\">not evaluated</td>";
}

std::string Row(const std::string& name, const std::string& value, const std::string& gate,
                Gate g) {
  return "<tr><td>" + HtmlEscape(name) + "</td><td class=\"num\">" + HtmlEscape(value) +
         "</td><td class=\"num\">" + HtmlEscape(gate) + "</td>" + GateCell(g) + "</tr>";
}

std::string InfoRow(const std::string& name, const std::string& value) {
  return "<tr><th>" + HtmlEscape(name) + "</th><td>" + HtmlEscape(value) + "</td></tr>";
}

}  // namespace

std::string HtmlEscape(std::string_view text) {
  std::string out;
  out.reserve(text.size());
  for (char c : text) {
    switch (c) {
      case '&':
        out += "&amp;";
        break;
      case '<':
        out += "&lt;";
        break;
      case '>':
        out += "&gt;";
        break;
      case '"':
        out += "&quot;";
        break;
      case '\'':
        out += "&#39;";
        break;
      default:
        out += c;
    }
  }
  return out;
}

std::string Base64(const unsigned char* data, size_t size) {
  static constexpr char kAlphabet[] =
      "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  std::string out;
  out.reserve((size + 2) / 3 * 4);
  size_t i = 0;
  for (; i + 3 <= size; i += 3) {
    const uint32_t v = (uint32_t{data[i]} << 16) | (uint32_t{data[i + 1]} << 8) | data[i + 2];
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += kAlphabet[(v >> 6) & 63];
    out += kAlphabet[v & 63];
  }
  if (i < size) {
    uint32_t v = uint32_t{data[i]} << 16;
    if (i + 1 < size) v |= uint32_t{data[i + 1]} << 8;
    out += kAlphabet[(v >> 18) & 63];
    out += kAlphabet[(v >> 12) & 63];
    out += i + 1 < size ? kAlphabet[(v >> 6) & 63] : '=';
    out += '=';
  }
  return out;
}

std::string Sha256Hex(std::string_view bytes) {
  unsigned char digest[EVP_MAX_MD_SIZE];
  unsigned int length = 0;
  if (EVP_Digest(bytes.data(), bytes.size(), digest, &length, EVP_sha256(), nullptr) != 1)
    return "";
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  for (unsigned int i = 0; i < length; ++i) {
    out += kHex[digest[i] >> 4];
    out += kHex[digest[i] & 15];
  }
  return out;
}

std::vector<BoardReprojection> ReprojectionPerCorrespondence(const ObservationSet& set,
                                                             const std::vector<double>& mean_px) {
  std::vector<BoardReprojection> out;
  if (mean_px.size() != set.observations.size()) return out;
  out.reserve(mean_px.size());
  for (size_t k = 0; k < mean_px.size(); ++k) {
    const BoardObservation& o = set.observations[k];
    out.push_back({o.board_index, o.T_camera_board.translation().norm(), mean_px[k]});
  }
  return out;
}

std::vector<std::string> BoardNames(const std::vector<BoardGeometry>& boards) {
  std::vector<std::string> names;
  for (const BoardGeometry& b : boards)
    names.push_back("board " + std::to_string(b.board_id) +
                    (b.pattern == BoardGeometry::PatternKind::kAprilTag
                         ? " (" + b.tag_family + " #" + std::to_string(b.tag_id) + ")"
                         : std::string(" (checkerboard)")));
  return names;
}

std::string RenderHtmlReport(const HtmlReportInput& in) {
  const CalibrationOutcome& out = in.outcome;
  const QualityFigures& q = out.quality;
  const VerdictConfig& v = in.gates;
  const ReportProvenance& p = in.provenance;
  const bool rejected = out.verdict == CalibrationOutcome::Verdict::kRejected;
  std::string verdict = VerdictName(out.verdict);
  std::string word = verdict;
  std::transform(word.begin(), word.end(), word.begin(),
                 [](char c) { return static_cast<char>(c >= 'a' && c <= 'z' ? c - 32 : c); });

  size_t image_bytes = 0;
  for (const auto& image : in.images) image_bytes += image.png.size() * 4 / 3 + 128;
  std::string s;
  s.reserve(64 * 1024 + image_bytes + in.reprojection.size() * 96);
  s += "<!DOCTYPE html>\n<html lang=\"en\"><head><meta charset=\"utf-8\">\n";
  // The page fetches nothing: pictures are data: URIs, the style is inline, there is no script.
  s += "<meta http-equiv=\"Content-Security-Policy\" content=\"default-src 'none'; img-src data:; "
       "style-src 'unsafe-inline'\">\n";
  s += "<title>calibd calibration: " + HtmlEscape(verdict) + "</title>\n<style>" + kStyle +
       "</style></head>\n<body>\n";

  // Verdict banner: the colour says accepted (green) or rejected (red) at a glance.
  s += "<header id=\"verdict\" data-verdict=\"" + HtmlEscape(verdict) +
       "\" style=\"background:" + (rejected ? kRed : kGreen) + "\">\n<p class=\"word\">" +
       HtmlEscape(word) + "</p>\n<p class=\"reason\">";
  if (out.reason != Reason::kNone)
    s += "<b>" + HtmlEscape(std::string(NameOf(out.reason))) + "</b>: ";
  s += HtmlEscape(out.detail) + "</p>\n";
  s += "<p class=\"reason\">T_camera_lidar from " + HtmlEscape(in.lidar_frame) + " to " +
       HtmlEscape(in.camera_frame) + ", calibrated " + HtmlEscape(UtcTime(p.generated_unix_s)) +
       "</p></header>\n<main>\n";

  s += "<section id=\"transform\"><h2>Extrinsic</h2>\n";
  if (!out.solved)
    s += "<p class=\"fail\">Not solved: the transform below is the prior or the grid search's "
         "candidate, not an estimate.</p>\n";
  s += "<p class=\"note\">T_camera_lidar maps points from the LiDAR frame (" +
       HtmlEscape(in.lidar_frame) + ") into the camera frame (" + HtmlEscape(in.camera_frame) +
       "): p_camera = T_camera_lidar p_lidar. Angles: R = Rz(yaw) Ry(pitch) Rx(roll).</p>\n";
  s += "<div class=\"blocks\">" + TransformBlock("T_camera_lidar", out.T_camera_lidar) +
       TransformBlock("T_lidar_camera (inverse)", out.T_camera_lidar.inverse()) +
       "</div></section>\n";

  s += "<section id=\"change\"><h2>Change against the prior</h2>\n<table>";
  s += "<tr><th></th><th>rotation [deg]</th><th>translation [m]</th></tr>";
  s += "<tr><td>change (angle of R_prior^T R, |t - t_prior|)</td><td class=\"num\">" +
       Num(out.delta_rotation_deg, 4) + "</td><td class=\"num\">" +
       Num(out.delta_translation_m, 4) + "</td></tr>";
  s += "<tr><td>verified below both</td><td class=\"num\">" + Num(v.verify_rotation_deg, 4) +
       "</td><td class=\"num\">" + Num(v.verify_translation_m, 4) + "</td></tr>";
  s += "<tr><td>rejected above either (mechanical tolerance)</td><td class=\"num\">" +
       Num(v.max_rotation_deg, 4) + "</td><td class=\"num\">" + Num(v.max_translation_m, 4) +
       "</td></tr>";
  if (in.truth_rotation_deg >= 0.0)
    s += "<tr><td>error against the ground truth</td><td class=\"num\">" +
         Num(in.truth_rotation_deg, 4) + "</td><td class=\"num\">" +
         Num(in.truth_translation_m, 4) + "</td></tr>";
  s += "</table>\n<div class=\"blocks\">" +
       TransformBlock("prior T_camera_lidar", out.prior_T_camera_lidar) + "</div></section>\n";

  // Quality figures against their gates; those computed after the solve are not evaluated when
  // the calibration stopped before it.
  const Gate solved = out.solved ? Gate::kPass : Gate::kNotReached;
  auto check = [&](bool ok) { return out.solved ? (ok ? Gate::kPass : Gate::kFail) : solved; };
  // A figure with an upper gate, each with its own number of decimals.
  auto at_most = [&](const std::string& name, double value, int value_digits, double max,
                     int max_digits) {
    return Row(name, Num(value, value_digits), "<= " + Num(max, max_digits), check(value <= max));
  };
  // A gate a site may set and the default leaves off (0): a figure only, where it is off.
  auto at_most_if_set = [&](const std::string& name, double value, int value_digits, double max,
                            int max_digits) {
    return max > 0.0 ? at_most(name, value, value_digits, max, max_digits)
                     : Row(name, Num(value, value_digits), "-", Gate::kNone);
  };
  // A figure one of the verdict's own gates judges (its estimate against the tolerance and its
  // sigma, verdict/gates/): the row's result is what those gates decided, so that the table
  // never shows a fail the verdict did not act on.
  const GateInput judge{in.camera, v, q, out.delta_rotation_deg, out.delta_translation_m};
  auto judged = [&](const std::string& name, double value, int value_digits,
                    const std::string& rule, std::initializer_list<calibd::Gate> gates) {
    bool ok = true;
    std::string detail;
    for (const calibd::Gate g : gates) ok = ok && g(judge, &detail) == Reason::kNone;
    return Row(name, Num(value, value_digits), rule, check(ok));
  };
  s += "<section id=\"quality\"><h2>Quality</h2>\n<table><tr><th>figure</th><th>value</th>"
       "<th>gate</th><th>result</th></tr>";
  s += Row("frame pairs used", std::to_string(q.frames_used), ">= " + std::to_string(v.min_frames),
           q.frames_used >= v.min_frames ? Gate::kPass : Gate::kFail);
  s += Row("board correspondences used", std::to_string(q.boards_used),
           ">= " + std::to_string(v.min_boards),
           q.boards_used >= v.min_boards ? Gate::kPass : Gate::kFail);
  s += Row("board-plane conditioning", Sci(q.plane_conditioning),
           ">= " + Sci(v.min_plane_conditioning),
           check(q.plane_conditioning >= v.min_plane_conditioning));
  s += at_most_if_set("formal rotation sigma [deg]", q.rotation_sigma_deg, 4,
                      v.max_rotation_sigma_deg, 4);
  s += at_most_if_set("formal translation sigma [m]", q.translation_sigma_m, 4,
                      v.max_translation_sigma_m, 4);
  s += at_most("half-data rotation spread [deg]", q.rotation_spread_deg, 4,
               v.max_rotation_spread_deg, 4);
  s += at_most("half-data translation spread [m]", q.translation_spread_m, 4,
               v.max_translation_spread_m, 4);
  s += at_most("solves from other starts, rotation [deg]", q.start_rotation_deg, 4,
               v.max_start_rotation_deg, 4);
  s += at_most("solves from other starts, translation [m]", q.start_translation_m, 4,
               v.max_start_translation_m, 4);
  if (std::isfinite(q.camera_scale_error))
    s += judged("camera vs LiDAR scale error [%] (sigma " + Num(q.camera_scale_sigma * 100.0, 3) +
                    (q.camera_scale_corrected != 0.0
                         ? "; corrected for " + Num(q.camera_scale_corrected * 100.0, 3)
                         : std::string()) +
                    ")",
                std::fabs(q.camera_scale_error) * 100.0, 3,
                "<= " + Num(v.max_camera_scale_error * 100.0, 3) + " or within " +
                    Num(kScaleSigmas, 0) + " sigma",
                {CheckCameraScale});
  if (std::isfinite(q.lidar_range_offset_m))
    s += judged("LiDAR range offset [m] (sigma " + Num(q.lidar_range_offset_sigma_m, 4) + ")",
                std::fabs(q.lidar_range_offset_m), 4,
                "<= " + Num(v.max_lidar_range_offset_m, 4) + " or within " +
                    Num(kRangeOffsetSigmas, 0) + " sigma",
                {CheckRangeOffset});
  if (q.board_bend_id >= 0)
    s += judged(
        "most bent board's bend [mm] (board " + std::to_string(q.board_bend_id) + ", sigma " +
            Num(q.board_bend_sigma_m * 1e3, 1) + ")",
        std::fabs(q.board_bend_m) * 1e3, 1,
        "<= " + Num(kMaxBoardBendM * 1e3, 1) + " or within " + Num(kBoardBendSigmas, 0) + " sigma",
        {CheckBoardFlatness});
  if (q.principal_point_fitted)
    s += judged(
        "principal point shift as a turn [deg] (" + Num(q.principal_point_shift_px.x(), 1) + ", " +
            Num(q.principal_point_shift_px.y(), 1) + " px, sigma " +
            Num(q.principal_point_sigma_px.x(), 1) + ", " + Num(q.principal_point_sigma_px.y(), 1) +
            ", blind to a common corner bias up to " + Num(q.principal_point_systematic_px.x(), 1) +
            ", " + Num(q.principal_point_systematic_px.y(), 1) + ")",
        q.principal_point_turn_deg, 3,
        "<= " + Num(kPrincipalPointTurnTolerances * v.verify_rotation_deg, 3) +
            " or not shown beyond its sigma; within the stated +-" +
            Num(q.principal_point_stated_sigma_px, 1) + " px" + StatedAsCheckedText(q),
        {CheckLensModel, CheckPrincipalPoint, CheckStatedPrincipalPoint});
  if (q.time_offset_fitted)
    s += judged("camera time offset [ms] (sigma " + Num(q.time_offset_sigma_s * 1e3, 1) +
                    ", corrected for " + Num(q.time_offset_corrected_s * 1e3, 1) + ")",
                std::fabs(q.time_offset_s) * 1e3, 1,
                "<= " + Num(v.max_time_offset_s * 1e3, 1) + " or within " +
                    Num(kTimeOffsetSigmas, 0) + " sigma",
                {CheckTimeOffset});
  s += at_most("reprojection error mean [px] (p95 " + Num(q.reprojection_p95_px, 2) + ")",
               q.reprojection_mean_px, 2, ReprojectionGate(in), 2);
  s += at_most("LiDAR residual RMS [m]", q.residual_rms_m, 4, v.max_residual_rms_m, 4);
  // The result's own predicted error bound (ErrorBound), which the verdict accepts only inside
  // the accuracy it must be known to (error_bound_gate.hpp).
  s += at_most("error bound, 99 %, rotation [deg]", q.rotation_bound_deg, 3,
               v.max_rotation_bound_deg, 2);
  s += at_most("error bound, 99 %, translation [m]", q.translation_bound_m, 4,
               v.max_translation_bound_m, 3);
  s += at_most("change vs prior, rotation [deg]", out.delta_rotation_deg, 4, v.max_rotation_deg, 2);
  s += at_most("change vs prior, translation [m]", out.delta_translation_m, 4, v.max_translation_m,
               3);
  s += "</table>\n<table>";
  s += InfoRow("camera-to-board distances [m]",
               Num(q.min_distance_m, 2) + " to " + Num(q.max_distance_m, 2));
  s += InfoRow("image coverage (4x4 cells holding a board centre)",
               Num(q.image_coverage * 100.0, 0) + " %");
  s += InfoRow("smallest information eigenvalue", Sci(q.min_information_eigenvalue));
  if (std::isfinite(q.rotation_bound_deg))
    s += InfoRow("error bound's parts (rotation, translation)",
                 "clustered sigma " + Num(q.rotation_clustered_sigma_deg, 4) + " deg, " +
                     Num(q.translation_clustered_sigma_m, 4) + " m; systematic " +
                     Num(q.rotation_systematic_deg, 3) +
                     " deg (the principal point, its tags' corners " +
                     CornerBiasName(q.principal_point_bound_corners) + "), " +
                     Num(q.translation_systematic_m, 4) + " m (range offset " +
                     Num(q.translation_bound_range_offset_m, 4) + ", scale " +
                     Num(q.translation_bound_scale_m, 4) + ", time offset " +
                     Num(q.translation_bound_time_offset_m, 4) + ", principal point " +
                     Num(q.translation_bound_principal_point_m, 4) + ", boards' centres " +
                     Num(q.translation_bound_board_centre_m, 4) + ")");
  if (q.board_centre_offset_id >= 0) {
    // An axis the camera could not see on both edges: "-".
    auto mm = [](double m, double sigma) {
      return std::isfinite(sigma) ? Num(m * 1e3, 1) + " +-" + Num(sigma * 1e3, 1)
                                  : std::string("-");
    };
    s += InfoRow("board centre about its tag, as the camera sees the board's edges (board " +
                     std::to_string(q.board_centre_offset_id) + ", right, up) [mm]",
                 mm(q.board_centre_offset_m.x(), q.board_centre_offset_sigma_m.x()) + ", " +
                     mm(q.board_centre_offset_m.y(), q.board_centre_offset_sigma_m.y()));
  }
  s += InfoRow("grid search: perturbation of the prior (roll, pitch, yaw) [deg]",
               Num(out.grid.perturbation_rpy_deg.x(), 2) + ", " +
                   Num(out.grid.perturbation_rpy_deg.y(), 2) + ", " +
                   Num(out.grid.perturbation_rpy_deg.z(), 2) + " (" +
                   std::to_string(out.grid.best_count) + " points in the regions, prior " +
                   std::to_string(out.grid.prior_count) + ")");
  s += InfoRow("motion compensation",
               std::to_string(out.motion.compensated) + " boards compensated, " +
                   std::to_string(out.motion.uncompensated) + " not (" +
                   std::to_string(out.motion.dropped) + " of them dropped), median shift " +
                   Num(out.motion.median_shift_m, 3) + " m, largest " +
                   Num(out.motion.max_shift_m, 3) + " m; velocities fitted over +-" +
                   Num(out.motion.window_s, 2) + " s, pairs " +
                   Num(out.motion.frame_interval_s, 2) + " s apart (median)");
  s += InfoRow("board-pose refinement", std::to_string(out.refined_boards) +
                                            " boards, mean change " +
                                            Num(out.board_rotation_change_deg, 3) + " deg / " +
                                            Num(out.board_translation_change_m, 4) + " m");
  s += InfoRow(
      "time: grid search, optimisation, quality [ms]",
      Num(out.grid.search_ms, 1) + ", " + Num(out.optimise_ms, 1) + ", " + Num(out.quality_ms, 1));
  s += "</table></section>\n";

  s += "<section id=\"thresholds\"><h2>Thresholds applied</h2>\n<table>";
  s += InfoRow("verified: change below",
               Num(v.verify_rotation_deg, 4) + " deg and " + Num(v.verify_translation_m, 4) + " m");
  s += InfoRow("rejected: change above (mechanical tolerance)",
               Num(v.max_rotation_deg, 4) + " deg or " + Num(v.max_translation_m, 4) + " m");
  s += InfoRow("min_frames (frame pairs with a correspondence)", std::to_string(v.min_frames));
  s += InfoRow("min_boards (board correspondences)", std::to_string(v.min_boards));
  const auto gate_or_off = [](double max, const char* unit) {
    return max > 0.0 ? Num(max, 4) + unit : std::string("off");
  };
  s += InfoRow("max formal sigma", gate_or_off(v.max_rotation_sigma_deg, " deg") + ", " +
                                       gate_or_off(v.max_translation_sigma_m, " m"));
  s += InfoRow("min board-plane conditioning", Sci(v.min_plane_conditioning));
  s += InfoRow("max half-data spread", Num(v.max_rotation_spread_deg, 4) + " deg, " +
                                           Num(v.max_translation_spread_m, 4) + " m");
  s += InfoRow(
      "max distance of solves from other starts",
      Num(v.max_start_rotation_deg, 4) + " deg, " + Num(v.max_start_translation_m, 4) + " m");
  {
    // The configured angle, what it is at this camera, and the gate applied where a sparse
    // LiDAR raised it (ReprojectionGatePx).
    const double focal_px = ReprojectionFocalPx(in.camera);
    const double angle_px = ReprojectionAnglePx(v, focal_px);
    const double applied = ReprojectionGate(in);
    s += InfoRow("max reprojection error mean",
                 Num(v.max_reprojection_mean_deg, 3) + " deg (" + Num(angle_px, 2) +
                     " px at the focal length, " + Num(focal_px, 0) + " px)" +
                     (applied > angle_px ? "; " + Num(applied, 2) +
                                               " px applied: " + Num(kReprojectionSpacingShare, 1) +
                                               " of the LiDAR's point spacing on the boards"
                                         : std::string()));
  }
  s += InfoRow("max LiDAR residual RMS", Num(v.max_residual_rms_m, 4) + " m");
  s += InfoRow("max error bound, 99 %", Num(v.max_rotation_bound_deg, 3) + " deg, " +
                                            Num(v.max_translation_bound_m, 4) + " m");
  s += "</table></section>\n";

  s += "<section id=\"per-board\"><h2>Reprojection error per board</h2>\n";
  s +=
      "<p class=\"note\">Paper Table I metric: each board fitted alone in the LiDAR frame, its tag "
      "corners mapped into the image through T_camera_lidar and compared with the detected "
      "corners; the mean over the board's correspondences.</p>\n";
  s += PerBoardPlot(in) + "</section>\n";
  s += "<section id=\"per-distance\"><h2>Reprojection error against distance</h2>\n";
  s += "<p class=\"note\">One point per correspondence (its corners' mean), coloured by board as "
       "above; the black line joins the means of each distance bin.</p>\n";
  s += DistancePlot(in) + "</section>\n";

  s += "<section id=\"overlays\"><h2>Overlays</h2>\n";
  if (in.images.empty()) s += "<p class=\"na\">No overlay pictures.</p>\n";
  for (const auto& image : in.images) {
    s += "<figure><img alt=\"" + HtmlEscape(image.caption) + "\" src=\"data:image/png;base64,";
    s += Base64(image.png.data(), image.png.size());
    s += "\"><figcaption>" + HtmlEscape(image.caption) + "</figcaption></figure>\n";
  }
  s += "</section>\n";

  s += "<section id=\"provenance\"><h2>Provenance</h2>\n<table>";
  s += InfoRow("software", p.software_version);
  s += InfoRow("report generated", UtcTime(p.generated_unix_s));
  s += InfoRow("input", p.input_path);
  s += InfoRow("config", p.config_path);
  s += InfoRow("config SHA-256", p.config_sha256);
  s += InfoRow("method", p.method);
  s += InfoRow("frames read (camera, LiDAR)",
               std::to_string(p.camera_frames) + ", " + std::to_string(p.lidar_frames));
  s += InfoRow("frame pairs", std::to_string(p.pairs) + " (unpaired: camera " +
                                  std::to_string(p.unpaired_camera) + ", LiDAR " +
                                  std::to_string(p.unpaired_lidar) + "; bad messages " +
                                  std::to_string(p.bad_messages) + ")");
  s += InfoRow("boards detected (camera, LiDAR)",
               std::to_string(p.camera_boards) + ", " + std::to_string(p.lidar_boards));
  s += InfoRow("used in the solve", std::to_string(q.frames_used) + " frame pairs, " +
                                        std::to_string(q.boards_used) + " correspondences");
  s += InfoRow("frames", in.camera_frame + " (camera), " + in.lidar_frame + " (LiDAR)");
  s += "</table></section>\n</main>\n</body></html>\n";
  return s;
}

bool WriteHtmlReport(const std::string& path, const HtmlReportInput& input, std::string* error) {
  return WriteFileAtomic(path, RenderHtmlReport(input), error);
}

}  // namespace calibd::tools
