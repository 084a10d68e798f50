#include "calibd/core/session/capture_order.hpp"

#include <algorithm>
#include <numeric>

namespace calibd {

std::vector<int> CaptureOrder(const SessionObservations& s, int* out_of_order, int* duplicates) {
  *out_of_order = *duplicates = 0;
  const auto& t = s.frame_times;
  if (static_cast<int>(t.size()) != s.num_frames ||
      std::all_of(t.begin(), t.end(), [](const FrameTimes& f) { return f.camera_utime == 0; }))
    return {};
  auto same = [&](size_t a, size_t b) {
    return t[a].camera_utime == t[b].camera_utime && t[a].lidar_utime == t[b].lidar_utime;
  };
  bool in_order_once = true;  // checked without allocating: the usual case
  for (size_t f = 1; f < t.size(); ++f) {
    *out_of_order += t[f].camera_utime < t[f - 1].camera_utime;
    in_order_once = in_order_once && t[f].camera_utime >= t[f - 1].camera_utime && !same(f, f - 1);
  }
  if (in_order_once) return {};
  std::vector<int> order(t.size());
  std::iota(order.begin(), order.end(), 0);
  std::stable_sort(order.begin(), order.end(),
                   [&](int a, int b) { return t[a].camera_utime < t[b].camera_utime; });
  std::vector<int> once;
  once.reserve(order.size());
  for (const int f : order) {
    if (!once.empty() && same(static_cast<size_t>(once.back()), static_cast<size_t>(f))) {
      ++*duplicates;
      continue;
    }
    once.push_back(f);
  }
  return once;
}

}  // namespace calibd
