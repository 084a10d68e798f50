#include "calibd/core/cluster_pca.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>

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

void AlignToPrincipalAxes(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                          Eigen::Vector3f* aligned) {
  const Eigen::Matrix3f Rt = pca.axes.transpose().cast<float>();
  const Eigen::Vector3f c = pca.centroid.cast<float>();
  for (int i = 0; i < n; ++i) aligned[i] = Rt * (points[i] - c);
}

}  // namespace calibd
