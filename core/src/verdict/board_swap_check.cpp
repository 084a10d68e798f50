#include "calibd/core/verdict/board_swap_check.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

namespace calibd {

namespace {

/// The side the camera's pose of a board rests on: the tag's, or the checkerboard's span.
double PatternSize(const BoardGeometry& g) {
  return g.pattern == BoardGeometry::PatternKind::kCheckerboard
             ? g.checker_square_size_m * std::max(1, g.checker_inner_cols - 1)
             : g.tag_size_m;
}

bool Seen(const SessionObservations& session, int board) {
  return std::any_of(
      session.camera.begin(), session.camera.end(),
      [&](const SessionObservations::CameraBoard& b) { return b.board_index == board; });
}

/// Pairs of boards a < b whose pattern sizes differ by kMinSwapSizeRatio or more.
template <typename Visit>
void ForPairsOfDifferentSizes(const std::vector<BoardGeometry>& boards, Visit visit) {
  const int n = static_cast<int>(boards.size());
  for (int a = 0; a < n; ++a) {
    for (int b = a + 1; b < n; ++b) {
      const BoardGeometry& ga = boards[static_cast<size_t>(a)];
      const BoardGeometry& gb = boards[static_cast<size_t>(b)];
      const double size_a = PatternSize(ga), size_b = PatternSize(gb);
      if (std::max(size_a, size_b) < kMinSwapSizeRatio * std::min(size_a, size_b)) continue;
      if (ga.pattern != gb.pattern) continue;  // a tag is not decoded as a checkerboard
      if (visit(a, b, size_a, size_b)) return;
    }
  }
}

}  // namespace

BoardSwap FindSwapInDistances(const std::vector<BoardGeometry>& boards,
                              const std::vector<BoardDistance>& distances) {
  std::vector<std::vector<double>> log_ratios(boards.size());
  for (const BoardDistance& d : distances) {
    const int i = d.observation->board_index;
    if (i < 0 || i >= static_cast<int>(boards.size()) || !(d.camera_m > 0.0) || !(d.lidar_m > 0.0))
      continue;
    log_ratios[static_cast<size_t>(i)].push_back(std::log(d.camera_m / d.lidar_m));
  }
  std::vector<double> median(boards.size(), std::numeric_limits<double>::quiet_NaN());
  for (size_t i = 0; i < boards.size(); ++i) {
    std::vector<double>& v = log_ratios[i];
    if (static_cast<int>(v.size()) < kMinSwapObservations) continue;
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    median[i] = v[v.size() / 2];
  }
  BoardSwap out;
  ForPairsOfDifferentSizes(boards, [&](int a, int b, double size_a, double size_b) {
    const double ra = median[static_cast<size_t>(a)], rb = median[static_cast<size_t>(b)];
    if (std::isnan(ra) || std::isnan(rb)) return false;
    const double q = std::log(size_a / size_b);  // board a's log ratio when swapped; b's is -q
    // Each board nearer its swapped ratio than 1, and off 1 by more than half of it; and so is
    // their difference, which a scale or distance error common to both boards leaves.
    const bool a_swapped = std::fabs(ra - q) < std::fabs(ra) && std::fabs(ra) > 0.5 * std::fabs(q);
    const bool b_swapped = std::fabs(rb + q) < std::fabs(rb) && std::fabs(rb) > 0.5 * std::fabs(q);
    const bool apart =
        std::fabs(ra - rb - 2.0 * q) < std::fabs(ra - rb) && std::fabs(ra - rb) > std::fabs(q);
    if (!a_swapped || !b_swapped || !apart) return false;
    out.found = true;
    out.board_a = a;
    out.board_b = b;
    out.ratio_a = std::exp(ra);
    out.ratio_b = std::exp(rb);
    return true;
  });
  return out;
}

BoardSwap FindSwappedBoards(const GridSearchConfig& config, const RangeImage& projection,
                            const std::vector<BoardGeometry>& boards,
                            const SessionObservations& session, const Pose& T_camera_lidar_prior,
                            int max_frames) {
  BoardSwap out;
  ForPairsOfDifferentSizes(boards, [&](int a, int b, double size_a, double size_b) {
    if (!Seen(session, a) || !Seen(session, b)) return false;
    SessionObservations swapped = session;
    for (SessionObservations::CameraBoard& c : swapped.camera) {
      if (c.board_index != a && c.board_index != b) continue;
      const bool was_a = c.board_index == a;
      c.T_camera_board.translation() *= was_a ? size_b / size_a : size_a / size_b;
      c.board_index = was_a ? b : a;
    }
    GridSearch grid(config, projection, boards);
    GridSearchResult r = grid.Run(swapped, T_camera_lidar_prior, nullptr, max_frames);
    if (r.status != GridSearchResult::Status::kOk) return false;
    out.found = true;
    out.board_a = a;
    out.board_b = b;
    out.grid = r;
    return true;
  });
  return out;
}

}  // namespace calibd
