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

void ComputeClusterPca(const Eigen::Vector3f* points, int n, ClusterPca* pca) {
  *pca = ClusterPca{};
  if (n <= 0) return;
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (int i = 0; i < n; ++i) sum += points[i].cast<double>();
  const Eigen::Vector3d c = sum / n;
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (int i = 0; i < n; ++i) {
    const Eigen::Vector3d d = points[i].cast<double>() - c;
    cov.noalias() += d * d.transpose();
  }
  cov /= n;
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
    third += q.cwiseProduct(q).cwiseProduct(q);
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

void AlignToPrincipalAxes(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                          Eigen::Vector3f* aligned) {
  const Eigen::Matrix3f Rt = pca.axes.transpose().cast<float>();
  const Eigen::Vector3f c = pca.centroid.cast<float>();
  for (int i = 0; i < n; ++i) aligned[i] = Rt * (points[i] - c);
}

}  // namespace calibd
