#pragma once
/// \file
/// Medians and percentiles of samples (reports, quality figures, bench tables).

#include <algorithm>
#include <vector>

namespace calibd {

/// The q-quantile (0..1) of `v` by nearest rank; 0 for an empty set. Sorts a copy.
inline double Quantile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  const size_t i = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size())));
  return v[i];
}

inline double Median(const std::vector<double>& v) { return Quantile(v, 0.5); }

}  // namespace calibd
