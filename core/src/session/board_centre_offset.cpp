#include "calibd/core/session/board_centre_offset.hpp"

#include <algorithm>
#include <array>
#include <cmath>
#include <limits>

#include "calibd/core/common/stats.hpp"

namespace calibd {

namespace {

constexpr int kStretches = 8;
constexpr int kMinStretches = 3;

// Student's t at 0.995 (two-sided 99 %) for 1 .. 7 degrees of freedom, over the normal's 2.576:
// how much wider a sigma from that few stretches' scatter is taken.
double FewStretchesWidening(int stretches) {
  constexpr std::array<double, 7> kT995 = {63.657, 9.925, 5.841, 4.604, 4.032, 3.707, 3.499};
  const size_t nu = static_cast<size_t>(std::clamp(stretches - 1, 1, 7));
  return kT995[nu - 1] / 2.576;
}

// Mean and widened sigma of `values` (one per observation, NaN where unmeasured) over the
// stretches `stretch_of` puts them in; sigma infinite under kMinStretches.
void StretchMean(const std::vector<double>& values, const std::vector<int>& stretch_of,
                 double* mean, double* sigma) {
  std::array<double, kStretches> sum{}, count{};
  for (size_t k = 0; k < values.size(); ++k) {
    if (!std::isfinite(values[k])) continue;
    sum[static_cast<size_t>(stretch_of[k])] += values[k];
    count[static_cast<size_t>(stretch_of[k])] += 1.0;
  }
  int g = 0;
  double m = 0.0, m2 = 0.0;
  for (int s = 0; s < kStretches; ++s) {
    if (count[static_cast<size_t>(s)] == 0.0) continue;
    const double x = sum[static_cast<size_t>(s)] / count[static_cast<size_t>(s)];
    ++g;
    m += x;
    m2 += x * x;
  }
  *mean = 0.0;
  *sigma = std::numeric_limits<double>::infinity();
  if (g < kMinStretches) return;
  m /= g;
  const double var = std::max(0.0, (m2 - g * m * m) / (g - 1));
  *mean = m;
  *sigma = std::sqrt(var / g) * FewStretchesWidening(g);
}

}  // namespace

BoardCentreOffsets EstimateBoardCentreOffsets(const ObservationSet& set, int num_boards) {
  BoardCentreOffsets out;
  const auto& obs = set.observations;
  if (obs.empty() || num_boards <= 0) return out;
  std::vector<int> frame_of(obs.size());
  for (size_t k = 0; k < obs.size(); ++k) frame_of[k] = obs[k].frame;
  const std::vector<int> stretch_of = FrameStretches(frame_of, kStretches);
  std::vector<double> x(obs.size()), y(obs.size());
  for (int b = 0; b < num_boards; ++b) {
    BoardCentreOffset c;
    c.board_index = b;
    Eigen::Matrix<double, 3, 2> axes = Eigen::Matrix<double, 3, 2>::Zero();
    int seen = 0;  // this board's observations, measured or not: the solve takes them all
    for (size_t k = 0; k < obs.size(); ++k) {
      const bool mine = obs[k].board_index == b;
      x[k] = mine ? obs[k].outline.CentreOffsetX() : std::numeric_limits<double>::quiet_NaN();
      y[k] = mine ? obs[k].outline.CentreOffsetY() : std::numeric_limits<double>::quiet_NaN();
      if (!mine) continue;
      ++seen;
      axes += obs[k].T_camera_board.linear().leftCols<2>();
      if (std::isfinite(x[k]) || std::isfinite(y[k])) ++c.observations;
    }
    if (c.observations == 0) continue;
    StretchMean(x, stretch_of, &c.offset_m.x(), &c.sigma_m.x());
    StretchMean(y, stretch_of, &c.offset_m.y(), &c.sigma_m.y());
    if (!std::isfinite(c.sigma_m.x()) && !std::isfinite(c.sigma_m.y())) continue;
    // An axis not measured counts as none: what the camera cannot see, this cannot bound.
    Eigen::Vector2d sigma = c.sigma_m, offset = c.offset_m;
    for (int a = 0; a < 2; ++a)
      if (!std::isfinite(sigma(a))) sigma(a) = offset(a) = 0.0;
    // This board's share of the translation: its observations' turned offsets, over all.
    const double share = static_cast<double>(seen) / static_cast<double>(obs.size());
    const Eigen::Matrix<double, 3, 2> mean_axes = axes / seen;
    out.translation_m += share * mean_axes * offset;
    out.translation_cov +=
        share * share * mean_axes * sigma.cwiseAbs2().asDiagonal() * mean_axes.transpose();
    out.boards.push_back(c);
  }
  return out;
}

}  // namespace calibd
