#pragma once
/// \file
/// The M2DP global descriptor of a point cluster (He, Wang & Zhang 2016, "M2DP: a novel 3D point
/// cloud descriptor and its application in loop closure detection"), as used by the paper
/// (§III-C-2) on PCA-aligned clusters, and the Pearson correlation used to match descriptors
/// (paper Eq. 1).
///
/// The cluster (centred, in its principal frame) is projected onto p x q planes whose normals
/// have elevations phi_i = i (pi/2) / p and azimuths theta_j = j pi / q (He §III-B). On each
/// plane the projections are counted in l concentric rings x t sectors: ring k spans radii
/// (r_max (k/l)^2, r_max ((k+1)/l)^2] (radii growing quadratically, r_max the distance of the
/// farthest point), sectors measured from the projection of the cluster's x axis onto the plane
/// (of its y axis for the one plane whose normal is the x axis). Row i*q + j of A (p*q x l*t) holds
/// the counts of plane (i, j); the descriptor is [u1; v1], the first left and right singular
/// vectors of A (He §III-C), found by power iteration on A^T A rather than a full SVD.
///
/// Sign rule: A >= 0, so by Perron-Frobenius its first singular vectors can be taken
/// non-negative; we flip (u1, v1) together so that sum(u1) >= 0. Pearson matching is sign
/// sensitive, so both a cluster and the references follow this rule.

#include <Eigen/Core>

namespace calibd {

struct M2dpConfig {
  int elevations = 4;        ///< p
  int azimuths = 16;         ///< q
  int rings = 8;             ///< l
  int sectors = 16;          ///< t
  int max_iterations = 100;  ///< power iteration cap
  double tolerance = 1e-6;   ///< stop when the right vector moves less than this (2-norm)
};

/// First singular pair (sigma1, u1, v1) of `A` by power iteration on A^T A, started from the
/// all-ones vector, with (u1, v1) signed so that sum(u1) >= 0. `u`, `v` and `scratch` must have
/// A.rows(), A.cols() and A.cols() entries; nothing is allocated. Returns the iterations used, or
/// -1 when A is zero (u, v set to zero).
int FirstSingularPair(const Eigen::MatrixXf& A, int max_iterations, double tolerance,
                      Eigen::VectorXf* u, Eigen::VectorXf* v, float* sigma,
                      Eigen::VectorXf* scratch);

/// Pearson correlation coefficient of two n-vectors (paper Eq. 1); 0 when either is constant.
double PearsonCorrelation(const float* a, const float* b, int n);

/// Computes M2DP descriptors with buffers sized once.
class M2dp {
 public:
  explicit M2dp(const M2dpConfig& config = M2dpConfig());

  int size() const { return rows_ + cols_; }  ///< p*q + l*t

  /// Descriptor of `n` points already centred and aligned to their principal axes
  /// (AlignToPrincipalAxes). Writes size() floats. Allocates nothing. Returns false when the
  /// cluster is degenerate (fewer than 2 distinct points); the descriptor is then zero.
  /// Each point adds weights[i] to its bins (nullptr: 1 each; see ComputeClusterPca).
  bool Compute(const Eigen::Vector3f* aligned, int n, float* descriptor,
               const float* weights = nullptr);

  /// The count matrix of the last Compute() (for tests).
  const Eigen::MatrixXf& counts() const { return A_; }

 private:
  M2dpConfig config_;
  int rows_ = 0, cols_ = 0;
  Eigen::Matrix<float, Eigen::Dynamic, 3, Eigen::RowMajor> basis_x_, basis_y_;  // per plane
  Eigen::MatrixXf A_;
  Eigen::VectorXf u_, v_, scratch_;
};

}  // namespace calibd
