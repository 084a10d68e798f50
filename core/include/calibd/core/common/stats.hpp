#pragma once
/// \file
/// Medians and percentiles of samples (reports, quality figures, bench tables), and stretches of
/// consecutive frames (clusters of errors that neighbouring frames share).

#include <algorithm>
#include <vector>

namespace calibd {

/// The q-quantile (0..1) of `v` by nearest rank; 0 for an empty set. Partly sorts a copy.
inline double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(i), v.end());
  return v[i];
}

inline double Median(const std::vector<double>& v) { return Quantile(v, 0.5); }

/// Per item of `frame_of` (its frame), the stretch of consecutive frames it lies in: the distinct
/// frames in order, cut into min(stretches, their count) runs of about equal count; indices in
/// [0, stretches).
inline std::vector<int> FrameStretches(const std::vector<int>& frame_of, int stretches) {
  std::vector<int> frames = frame_of;
  std::sort(frames.begin(), frames.end());
  frames.erase(std::unique(frames.begin(), frames.end()), frames.end());
  const long runs = std::min<long>(stretches, static_cast<long>(frames.size()));
  std::vector<int> stretch_of(frame_of.size());
  for (size_t k = 0; k < frame_of.size(); ++k) {
    const long rank = std::lower_bound(frames.begin(), frames.end(), frame_of[k]) - frames.begin();
    stretch_of[k] = static_cast<int>(rank * runs / static_cast<long>(frames.size()));
  }
  return stretch_of;
}

}  // namespace calibd
