#include "calibd/core/camera/board_outline.hpp"

#include <algorithm>
#include <cmath>

namespace calibd {

namespace {

constexpr int kSamplesPerEdge = 16;
constexpr double kSampledShare = 0.7;  // of each edge's length, about its middle
// How far the search reaches beyond the configured edge, and inside it (no closer to the
// pattern than kPatternGuardM): a tag 40 mm off-centre, a board 5 % off its configured size.
constexpr double kSearchM = 0.05;
constexpr double kPatternGuardM = 0.005;
constexpr double kStepPx = 0.5;
constexpr int kMaxSteps = 512;
// The weakest edge trusted, grey levels per pixel: well above an 8-bit image's noise after the
// central difference over a pixel.
constexpr double kMinEdgeGreyPerPx = 6.0;
constexpr double kFoundShare = 0.5;  // of an edge's samples that must find an edge
constexpr double kAgreeShare = 0.5;  // ... and agree with their median to kAgreePx
constexpr double kAgreePx = 1.5;

// Bilinear grey level at (u, v) (OpenCV convention: pixel centres at integers); the caller keeps
// it inside the image.
double Grey(const ImageView& im, double u, double v) {
  const int x = std::clamp(static_cast<int>(std::floor(u)), 0, im.width - 2);
  const int y = std::clamp(static_cast<int>(std::floor(v)), 0, im.height - 2);
  const double a = u - x, b = v - y;
  const uint8_t* r0 = im.data + static_cast<size_t>(y) * static_cast<size_t>(im.stride) + x;
  const uint8_t* r1 = r0 + im.stride;
  return (1.0 - b) * ((1.0 - a) * r0[0] + a * r0[1]) + b * ((1.0 - a) * r1[0] + a * r1[1]);
}

// Along one search segment (board-plane distances `from` .. `to` from the board's centre along
// the edge's normal), the first edge going outward as a distance along the normal; NaN when
// none. `px_per_m`: the segment's scale in the image.
double FindEdge(const ImageView& im, const CameraModel& camera, const Pose& T_camera_board,
                const Eigen::Vector2d& normal, const Eigen::Vector2d& along, double s, double from,
                double to, double* px_per_m) {
  constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();
  const auto at = [&](double d) {
    const Eigen::Vector2d p = d * normal + s * along;
    return Eigen::Vector3d(T_camera_board * Eigen::Vector3d(p.x(), p.y(), 0.0));
  };
  Eigen::Vector2d uv0, uv1;
  if (!camera.Project(at(from), &uv0, -2.0) || !camera.Project(at(to), &uv1, -2.0)) return kNaN;
  const double length_px = (uv1 - uv0).norm();
  *px_per_m = length_px / (to - from);
  const int steps = std::min(kMaxSteps - 1, static_cast<int>(std::ceil(length_px / kStepPx)));
  if (steps < 4) return kNaN;
  const double step_px = length_px / steps;
  std::array<double, kMaxSteps> grey;
  for (int j = 0; j <= steps; ++j) {
    const Eigen::Vector2d uv = uv0 + (uv1 - uv0) * (static_cast<double>(j) / steps);
    grey[static_cast<size_t>(j)] = Grey(im, uv.x(), uv.y());
  }
  // |d grey / d px| by central differences, at steps 1 .. steps - 1.
  std::array<double, kMaxSteps> slope;
  double strongest = 0.0;
  for (int j = 1; j < steps; ++j) {
    slope[static_cast<size_t>(j)] =
        std::fabs(grey[static_cast<size_t>(j + 1)] - grey[static_cast<size_t>(j - 1)]) /
        (2.0 * step_px);
    strongest = std::max(strongest, slope[static_cast<size_t>(j)]);
  }
  if (strongest < kMinEdgeGreyPerPx) return kNaN;
  for (int j = 2; j < steps - 1; ++j) {
    const double a = slope[static_cast<size_t>(j - 1)], b = slope[static_cast<size_t>(j)],
                 c = slope[static_cast<size_t>(j + 1)];
    if (b < 0.5 * strongest || b < a || b < c) continue;
    const double curvature = a - 2.0 * b + c;
    const double shift = curvature < 0.0 ? std::clamp(0.5 * (a - c) / curvature, -0.5, 0.5) : 0.0;
    return from + (to - from) * (j + shift) / steps;
  }
  return kNaN;
}

}  // namespace

BoardOutline MeasureBoardOutline(const ImageView& image, const CameraModel& camera,
                                 const BoardGeometry& board, const Pose& T_camera_board) {
  BoardOutline out;
  if (!image.data || image.width < 2 || image.height < 2) return out;
  // The printed pattern's half extent about its centre (a checkerboard's outer squares beyond
  // its outermost inner corners).
  const Eigen::Vector2d pattern_half =
      board.pattern == BoardGeometry::PatternKind::kAprilTag
          ? Eigen::Vector2d::Constant(0.5 * board.tag_size_m)
          : Eigen::Vector2d(0.5 * (board.checker_inner_cols + 1) * board.checker_square_size_m,
                            0.5 * (board.checker_inner_rows + 1) * board.checker_square_size_m);
  for (int e = 0; e < kBoardEdges; ++e) {
    const int axis = e / 2;  // 0: x_B (left, right), 1: y_B (bottom, top)
    const double sign = e % 2 == 0 ? -1.0 : 1.0;
    Eigen::Vector2d normal = Eigen::Vector2d::Zero(), along = Eigen::Vector2d::Zero();
    normal(axis) = sign;
    along(1 - axis) = 1.0;
    const double edge = 0.5 * (axis == 0 ? board.width_m : board.height_m);
    const double length = axis == 0 ? board.height_m : board.width_m;
    const double pattern = sign * board.tag_offset_m(axis) + pattern_half(axis) + kPatternGuardM;
    const double from = std::max(pattern, edge - kSearchM), to = edge + kSearchM;
    if (!(to - from > 2.0 * kPatternGuardM)) continue;
    std::array<double, kSamplesPerEdge> found;
    int n = 0;
    double px_per_m = 0.0;
    for (int i = 0; i < kSamplesPerEdge; ++i) {
      const double s = length * kSampledShare * ((i + 0.5) / kSamplesPerEdge - 0.5);
      double scale = 0.0;
      const double d = FindEdge(image, camera, T_camera_board, normal, along, s, from, to, &scale);
      if (!std::isfinite(d)) continue;
      found[static_cast<size_t>(n++)] = d - edge;
      px_per_m = std::max(px_per_m, scale);
    }
    if (n < kFoundShare * kSamplesPerEdge || !(px_per_m > 0.0)) continue;
    std::nth_element(found.begin(), found.begin() + n / 2, found.begin() + n);
    const double median = found[static_cast<size_t>(n / 2)];
    const int agree =
        static_cast<int>(std::count_if(found.begin(), found.begin() + n, [&](double d) {
          return std::fabs(d - median) * px_per_m <= kAgreePx;
        }));
    if (agree >= kAgreeShare * kSamplesPerEdge)
      out.edge_offset_m[static_cast<size_t>(e)] = static_cast<float>(median);
  }
  return out;
}

}  // namespace calibd
