#pragma once
/// \file
/// Principal component analysis of a point cluster and its alignment to the principal axes (paper
/// §III-C-2: "the points of a cluster are transformed ... to the eigen space defined by the
/// principal axes and cluster center"), which makes the M2DP descriptor invariant to where the
/// cluster is and how it is turned.

#include <Eigen/Core>

namespace calibd {

struct ClusterPca {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< LiDAR frame, m
  /// Principal axes as columns, by decreasing variance; a rotation (right-handed). Column 2 is
  /// the normal of a planar cluster.
  Eigen::Matrix3d axes = Eigen::Matrix3d::Identity();
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  ///< variances, decreasing, m^2
  Eigen::Vector3d extents = Eigen::Vector3d::Zero();      ///< max - min along each axis, m
  /// sqrt(lambda3 / lambda2): 0 for a perfect plane, larger for thick or curved clusters.
  double planarity() const;
};

/// PCA of `n` points. Sign rule for the axes (the eigenvectors are defined up to sign): the first
/// two axes point towards the side with the positive third moment sum((p - c) . e)^3, i.e.
/// towards the cluster's longer tail, and the third is their cross product so that the alignment
/// is a proper rotation. For a rigid motion of the cluster the rule picks the moved axes, so the
/// aligned points do not change (up to ties of symmetric clusters).
void ComputeClusterPca(const Eigen::Vector3f* points, int n, ClusterPca* pca);

/// Writes axes^T (p - centroid) of each point: the cluster in its principal frame.
void AlignToPrincipalAxes(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                          Eigen::Vector3f* aligned);

}  // namespace calibd
