#pragma once
/// \file
/// Principal component analysis of a point cluster and its alignment to the principal axes (paper
/// §III-C-2: "the points of a cluster are transformed ... to the eigen space defined by the
/// principal axes and cluster center"), which makes the M2DP descriptor invariant to where the
/// cluster is and how it is turned.

#include <Eigen/Core>
#include <utility>

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

/// PCA of `n` points, each weighted by weights[i] (nullptr: all 1) in the centroid, the covariance
/// and the sign rule: a weight is the share of the surface a sample stands for, so that a scan
/// pattern's dense and sparse parts count alike. Sign rule for the axes (the eigenvectors are
/// defined up to sign): the first two axes point towards the side with the positive third moment
/// sum((p - c) . e)^3, i.e. towards the cluster's longer tail, and the third is their cross product
/// so that the alignment is a proper rotation. For a rigid motion of the cluster the rule picks the
/// moved axes, so the aligned points do not change (up to ties of symmetric clusters).
void ComputeClusterPca(const Eigen::Vector3f* points, int n, ClusterPca* pca,
                       const float* weights = nullptr);

/// Sides (long, short) of the smallest-area rectangle around the cluster's points projected onto
/// its principal plane (the first two axes), searched over `num_angles` orientations in [0, 90)
/// degrees: the size of a board whatever its turn in its own plane, where the PCA extents of a
/// square run along any direction (its two in-plane variances are equal) and reach its diagonal.
Eigen::Vector2d InPlaneRectangle(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                                 int num_angles = 18);

/// A side_u x side_v rectangle in a cluster's principal plane, turned by `angle_rad` from the first
/// axis: points whose (u, v) lie in [u0, u0 + side_u] x [v0, v0 + side_v].
struct PlaneWindow {
  double angle_rad = 0.0;
  float side_u = 0.0f, side_v = 0.0f;
  float u0 = 0.0f, v0 = 0.0f;
  int count = 0;  ///< cluster points inside
  bool Contains(const ClusterPca& pca, const Eigen::Vector3f& point) const;
};

/// The w x h rectangle in the cluster's plane (either side along either axis) that holds the most
/// of its points and cuts through the fewest: the board among a strip of another surface crossing
/// its plane beside it, which the plane's outline would otherwise include. Searched over
/// `num_angles` turns in [0, 90) degrees, refined to a tenth of that step; per turn the window
/// along the first side is placed where it holds the most points, then the one along the second
/// among those; then shifted by up to 5 cm to where it leaves the fewest points in its row and
/// column bands (a strip as dense as the board ties with it on the count alone). `scratch` holds
/// n entries.
PlaneWindow MostPointsWindow(const ClusterPca& pca, const Eigen::Vector3f* points, int n, double w,
                             double h, std::pair<float, float>* scratch, int num_angles = 30);

/// Writes axes^T (p - centroid) of each point: the cluster in its principal frame.
void AlignToPrincipalAxes(const ClusterPca& pca, const Eigen::Vector3f* points, int n,
                          Eigen::Vector3f* aligned);

}  // namespace calibd
