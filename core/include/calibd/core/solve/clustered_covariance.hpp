#pragma once
/// \file
/// The extrinsic's covariance robust to errors that residuals share: the cluster-robust
/// ("sandwich") covariance of Liang & Zeger (1986), clustered two ways as in Cameron, Gelbach &
/// Miller (2011, "Robust inference with multiway clustering").
///
/// The formal covariance sigma^2 (J^T J)^-1 treats every LiDAR point's residual as independent.
/// They are not: the points of one board observation share its camera pose error (PnP), those of
/// one board share its size, flatness and tag placement errors over the whole session, and the
/// frames of one stretch of a drive share its motion and timing errors. Clean simulated sessions
/// ended 2-6 times their formal sigma from the truth. With H = J^T J and s_k = J^T r the score of
/// board observation k at the solution (both of the robust residuals the solve minimised), a
/// clustering C of the observations gives
///   M_C = G / (G - 1) * sum over clusters c of (sum_{k in c} s_k)(sum_{k in c} s_k)^T,
/// G its number of clusters, and the covariance is H^-1 M H^-1 with M = M_board + M_stretch. That
/// sum is the conservative side of the two-way estimator (Cameron et al. subtract the clustering
/// by both, which can leave M indefinite with few clusters and leaves nothing with one board);
/// with fewer than two boards, M = M_stretch.

#include <Eigen/Core>
#include <vector>

namespace calibd {

/// One board observation's score J^T r (tangent [dt, dtheta]) and what clusters it.
struct ObservationScore {
  int board = -1;  ///< configured board index
  int frame = -1;  ///< frame pair index (capture order)
  Eigen::Matrix<double, 6, 1> score = Eigen::Matrix<double, 6, 1>::Zero();
};

struct ClusteredCovariance {
  /// False when H is singular or the observations fall into fewer than two stretches.
  bool valid = false;
  Eigen::Matrix<double, 6, 6> covariance = Eigen::Matrix<double, 6, 6>::Zero();  ///< m, rad
  int boards = 0;                                                                ///< board clusters
  int stretches = 0;  ///< stretch clusters
};

/// The frames the observations come from are split, in frame order, into `stretches` runs of
/// consecutive frames as equal in number as they can be (fewer when there are fewer frames).
ClusteredCovariance ClusterRobustCovariance(const Eigen::Matrix<double, 6, 6>& information,
                                            const std::vector<ObservationScore>& scores,
                                            int stretches);

}  // namespace calibd
