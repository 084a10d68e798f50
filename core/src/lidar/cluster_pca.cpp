#include "calibd/core/lidar/cluster_pca.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <limits>

namespace calibd {

double ClusterPca::planarity() const {
  if (eigenvalues(1) <= 0.0) return 1.0;
  return std::sqrt(std::max(0.0, eigenvalues(2)) / eigenvalues(1));
}

void ComputeClusterPca(const Eigen::Vector3f* points, int n, ClusterPca* pca,
                       const float* weights) {
  *pca = ClusterPca{};
  if (n <= 0) return;
  auto weight = [weights](int i) { return weights ? static_cast<double>(weights[i]) : 1.0; };
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  double total = 0.0;
  for (int i = 0; i < n; ++i) {
    sum += weight(i) * points[i].cast<double>();
    total += weight(i);
  }
  if (!(total > 0.0)) return;
  const Eigen::Vector3d c = sum / total;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d = points[i].cast<double>() - c;
    cov.noalias() += weight(i) * d * d.transpose();
  }
  cov /= total;
  // Closed-form 3x3 solver: eigenvalues in increasing order.
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> solver;
  solver.computeDirect(cov);
  Eigen::Matrix3d axes;
  for (int k = 0; k < 3; ++k) axes.col(k) = solver.eigenvectors().col(2 - k);
  pca->eigenvalues = solver.eigenvalues().reverse();

  Eigen::Vector3d third = Eigen::Vector3d::Zero();
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e300), hi = -lo;
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d q = axes.transpose() * (points[i].cast<double>() - c);
    third += weight(i) * q.cwiseProduct(q).cwiseProduct(q);
    lo = lo.cwiseMin(q);
    hi = hi.cwiseMax(q);
  }
  for (int k = 0; k < 2; ++k) {
    if (third(k) < 0.0) {
      axes.col(k) = -axes.col(k);
      std::swap(lo(k), hi(k));
      lo(k) = -lo(k);
      hi(k) = -hi(k);
    }
  }
  axes.col(2) = axes.col(0).cross(axes.col(1));
  pca->centroid = c;
  pca->axes = axes;
  pca->extents = hi - lo;
}

Eigen::Vector2d InPlaneRectangle(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                                 int num_angles) {
  if (n <= 0 || num_angles < 1) return Eigen::Vector2d::Zero();
  const Eigen::Vector3f c = pca.centroid.cast<float>();
  const Eigen::Vector3f e0 = pca.axes.col(0).cast<float>(), e1 = pca.axes.col(1).cast<float>();
  Eigen::Vector2d best(0.0, 0.0);
  double best_area = 1e300;
  for (int a = 0; a < num_angles; ++a) {
    const double angle = (M_PI / 2.0) * a / num_angles;
    const float ca = static_cast<float>(std::cos(angle)), sa = static_cast<float>(std::sin(angle));
    const Eigen::Vector3f u = ca * e0 + sa * e1, v = -sa * e0 + ca * e1;
    float u_lo = 1e30f, u_hi = -1e30f, v_lo = 1e30f, v_hi = -1e30f;
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3f d = points[i] - c;
      const float pu = u.dot(d), pv = v.dot(d);
      u_lo = std::min(u_lo, pu);
      u_hi = std::max(u_hi, pu);
      v_lo = std::min(v_lo, pv);
      v_hi = std::max(v_hi, pv);
    }
    const double su = u_hi - u_lo, sv = v_hi - v_lo;
    if (su * sv < best_area) {
      best_area = su * sv;
      best = Eigen::Vector2d(std::max(su, sv), std::min(su, sv));
    }
  }
  return best;
}

namespace {

// Start of the window of length `side` over the values sorted[0..n).first (ascending) holding the
// most of them; `count` receives how many.
float BestWindowStart(const std::pair<float, float>* sorted, int n, float side, int* count) {
  int best = 0, best_start = 0;
  for (int lo = 0, hi = 0; lo < n; ++lo) {
    while (hi < n && sorted[hi].first <= sorted[lo].first + side) ++hi;
    if (hi - lo > best) {
      best = hi - lo;
      best_start = lo;
    }
  }
  *count = best;
  return n > 0 ? sorted[best_start].first : 0.0f;
}

// (u, v) of each of n points along a window's sides, turned by `angle` in the cluster's principal
// plane, into uv: one arithmetic for the search and for Contains, so that a point falls on the
// same side of an edge in both.
void WindowCoordinates(const ClusterPca& pca, double angle, const Eigen::Vector3f* points, int n,
                       std::pair<float, float>* uv) {
  const Eigen::Matrix3f Rt = pca.axes.transpose().cast<float>();
  const Eigen::Vector3f c = pca.centroid.cast<float>();
  const float ca = static_cast<float>(std::cos(angle)), sa = static_cast<float>(std::sin(angle));
  const Eigen::Vector2f eu(ca, sa), ev(-sa, ca);
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3f d = Rt * (points[i] - c);
    uv[i] = {eu.dot(d.head<2>()), ev.dot(d.head<2>())};
  }
}

bool ByFirst(const std::pair<float, float>& a, const std::pair<float, float>& b) {
  return a.first < b.first;
}

// x within the span [lo, lo + side].
bool InSpan(float x, float lo, float side) { return x >= lo && x <= lo + side; }

}  // namespace

bool PlaneWindow::Contains(const ClusterPca& pca, const Eigen::Vector3f& point) const {
  std::pair<float, float> uv;
  WindowCoordinates(pca, angle_rad, &point, 1, &uv);
  return InSpan(uv.first, u0, side_u) && InSpan(uv.second, v0, side_v);
}

PlaneWindow MostPointsWindow(const ClusterPca& pca, const Eigen::Vector3f* points, int n, double w,
                             double h, std::pair<float, float>* scratch, int num_angles) {
  PlaneWindow best, result;
  if (n <= 0 || num_angles < 1) return best;
  // The count-best window at `angle` into `best` when it holds more than `best` does.
  auto try_angle = [&](double angle) {
    for (int turn = 0; turn < (w == h ? 1 : 2); ++turn) {
      const float side_u = static_cast<float>(turn == 0 ? w : h);
      const float side_v = static_cast<float>(turn == 0 ? h : w);
      WindowCoordinates(pca, angle, points, n, scratch);
      // By u alone: the window's start and count need only the u order, and the v of the points
      // it holds are sorted on their own below.
      std::sort(scratch, scratch + n, ByFirst);
      int count_u = 0;
      const float u0 = BestWindowStart(scratch, n, side_u, &count_u);
      if (count_u <= best.count) continue;  // the second side can only lose points
      // The window's points by their v.
      int m = 0;
      for (int i = 0; i < n; ++i)
        if (InSpan(scratch[i].first, u0, side_u)) scratch[m++] = {scratch[i].second, 0.0f};
      std::sort(scratch, scratch + m, ByFirst);
      int count = 0;
      const float v0 = BestWindowStart(scratch, m, side_v, &count);
      if (count > best.count) best = PlaneWindow{angle, side_u, side_v, u0, v0, count};
    }
  };
  // Coarse turns by the count alone.
  const double step = (M_PI / 2.0) / num_angles;
  for (int a = 0; a < num_angles; ++a) try_angle(step * a);
  if (best.count == 0) return best;
  // A window of the board's own size loses a wedge of it when turned a little off (2 cm along a
  // 0.8 m side per 1.5 deg), and a strip as dense as the board along its edge ties with it on the
  // count: a window shifted onto the strip by a column holds as many points. The board's own
  // window cuts through nothing. Around the coarse turn (to a tenth of its step) and its
  // count-best place (by kShiftM steps), the window kept has the most of
  // 2 x inside - in_u_band - in_v_band: points inside, less those beside it in its row and column
  // bands (inside its u range but not its v range, or the reverse).
  static constexpr int kTurnSteps = 5, kShiftSteps = 5;
  static constexpr float kShiftM = 0.005f;
  const PlaneWindow coarse = best;
  int best_score = std::numeric_limits<int>::min();
  for (int k = -kTurnSteps; k <= kTurnSteps; ++k) {
    best = PlaneWindow{};
    try_angle(coarse.angle_rad + 0.1 * step * k);
    if (best.count == 0) continue;
    const PlaneWindow centre = best;
    WindowCoordinates(pca, centre.angle_rad, points, n, scratch);
    // Each shifted window's count of points inside, in its row band and in its column band,
    // without testing every point against every shift: the shifts along u that hold a point's u
    // are one run of a (the window's edges move up together), and so are those along v; the
    // point adds 1 to in_u over its u run, to in_v over its v run and to inside over the product
    // of both (a 2D difference array, summed afterwards). The same float comparisons as InSpan.
    constexpr int kShifts = 2 * kShiftSteps + 1;
    float u_lo[kShifts], v_lo[kShifts];
    for (int a = 0; a < kShifts; ++a) {
      u_lo[a] = centre.u0 + static_cast<float>(a - kShiftSteps) * kShiftM;
      v_lo[a] = centre.v0 + static_cast<float>(a - kShiftSteps) * kShiftM;
    }
    // The run [first, last] of shifts whose span holds x (first > last: none).
    auto run = [](float x, const float* lo, float side, int* first, int* last) {
      *first = 0;
      while (*first < kShifts && !InSpan(x, lo[*first], side)) ++*first;
      *last = *first - 1;
      while (*last + 1 < kShifts && InSpan(x, lo[*last + 1], side)) ++*last;
    };
    int in_u[kShifts + 1] = {}, in_v[kShifts + 1] = {};
    int inside[kShifts + 1][kShifts + 1] = {};
    for (int i = 0; i < n; ++i) {
      int a0 = 0, a1 = 0, b0 = 0, b1 = 0;
      run(scratch[i].first, u_lo, centre.side_u, &a0, &a1);
      run(scratch[i].second, v_lo, centre.side_v, &b0, &b1);
      if (a0 <= a1) {
        ++in_u[a0];
        --in_u[a1 + 1];
      }
      if (b0 <= b1) {
        ++in_v[b0];
        --in_v[b1 + 1];
      }
      if (a0 <= a1 && b0 <= b1) {
        ++inside[a0][b0];
        --inside[a0][b1 + 1];
        --inside[a1 + 1][b0];
        ++inside[a1 + 1][b1 + 1];
      }
    }
    for (int a = 0; a < kShifts; ++a) {
      in_u[a + 1] += in_u[a];
      in_v[a + 1] += in_v[a];
    }
    for (int a = 0; a <= kShifts; ++a)
      for (int b = 0; b <= kShifts; ++b)
        inside[a][b] += (a > 0 ? inside[a - 1][b] : 0) + (b > 0 ? inside[a][b - 1] : 0) -
                        (a > 0 && b > 0 ? inside[a - 1][b - 1] : 0);
    for (int a = 0; a < kShifts; ++a) {
      for (int b = 0; b < kShifts; ++b) {
        const int score = 2 * inside[a][b] - in_u[a] - in_v[b];
        if (score > best_score) {
          best_score = score;
          result = centre;
          result.u0 = u_lo[a];
          result.v0 = v_lo[b];
          result.count = inside[a][b];
        }
      }
    }
  }
  return result;
}

void AlignToPrincipalAxes(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                          Eigen::Vector3f* aligned) {
  const Eigen::Matrix3f Rt = pca.axes.transpose().cast<float>();
  const Eigen::Vector3f c = pca.centroid.cast<float>();
  for (int i = 0; i < n; ++i) aligned[i] = Rt * (points[i] - c);
}

}  // namespace calibd
