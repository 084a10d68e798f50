#pragma once
/// \file
/// Each board observation's distance along its plane's normal as the camera measures it (PnP) and
/// as the LiDAR does (its points under an extrinsic), and the weighted linear fit of their
/// differences. The camera-LiDAR checks beyond the paper are such fits, each with its own terms:
/// the camera's scale and the LiDAR's range offset (calibration_engine.cpp), the camera's time
/// offset (board_motion.hpp).

#include <Eigen/Core>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <utility>
#include <vector>

#include "calibd/core/board_observation.hpp"
#include "calibd/core/geometry.hpp"

namespace calibd {

struct BoardDistance {
  const BoardObservation* observation = nullptr;
  /// The board plane's normal in the camera frame, turned away from the camera.
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();
  double camera_m = 0.0;  ///< normal . (PnP board centre): the camera's distance to the plane
  double lidar_m = 0.0;   ///< median of normal . p over the board's points in the camera frame
  /// Unit mean direction from the LiDAR to the board's points, camera frame: a range offset b
  /// moves the LiDAR's plane by b (normal . mean_ray).
  Eigen::Vector3d mean_ray = Eigen::Vector3d::Zero();
  /// PnP's distance error grows with the distance over the tag's side in the image: its inverse,
  /// tag side (px) / distance (m), weighs the row so that small far tags do not drown the rest.
  double weight = 0.0;
};

/// Observations with fewer LiDAR points leave no distance.
inline constexpr int kMinBoardDistancePoints = 10;
/// Frames of a board per block of the cluster-robust sigma (consecutive frames of a board share
/// their errors).
inline constexpr int kDistanceBlockFrames = 10;

/// One row per observation of `set` with kMinBoardDistancePoints points or more.
std::vector<BoardDistance> BoardDistances(const ObservationSet& set, const Pose& T_camera_lidar);

/// Weighted least squares y = A x over rows (already weighted) grouped in blocks of
/// kDistanceBlockFrames frames of a board, with two covariances: the least-squares one from the
/// residuals, and the cluster-robust sandwich over the blocks (Liang & Zeger), which also counts
/// errors shared within a block.
template <int K>
struct DistanceFit {
  bool fitted = false;  ///< more rows than unknowns, and A^T A invertible
  Eigen::Matrix<double, K, 1> x = Eigen::Matrix<double, K, 1>::Zero();
  Eigen::Matrix<double, K, K> cov_ls = Eigen::Matrix<double, K, K>::Zero();
  Eigen::Matrix<double, K, K> cov_cluster = Eigen::Matrix<double, K, K>::Zero();
  int rows = 0, blocks = 0;
  /// The larger of the two sigmas of unknown i (the cluster one only over enough blocks to be
  /// estimated).
  double Sigma(int i, int min_blocks) const {
    const double ls = cov_ls(i, i);
    const double cluster = blocks >= min_blocks ? cov_cluster(i, i) : 0.0;
    return std::sqrt(std::max(0.0, std::max(ls, cluster)));
  }
};

template <int K>
class DistanceFitter {
 public:
  /// Adds the row a . x = y (a and y weighted by the caller) of observation `o`.
  void Add(const BoardObservation& o, const Eigen::Matrix<double, K, 1>& a, double y) {
    const auto key = std::make_pair(o.board_index, o.frame / kDistanceBlockFrames);
    const int block = blocks_.emplace(key, static_cast<int>(blocks_.size())).first->second;
    rows_.push_back({a, y, block});
  }

  DistanceFit<K> Fit() const {
    DistanceFit<K> fit;
    fit.rows = static_cast<int>(rows_.size());
    fit.blocks = static_cast<int>(blocks_.size());
    if (fit.rows <= K) return fit;
    Eigen::Matrix<double, K, K> AtA = Eigen::Matrix<double, K, K>::Zero();
    Eigen::Matrix<double, K, 1> Aty = Eigen::Matrix<double, K, 1>::Zero();
    for (const Row& r : rows_) {
      AtA += r.a * r.a.transpose();
      Aty += r.a * r.y;
    }
    const Eigen::FullPivLU<Eigen::Matrix<double, K, K>> lu(AtA);
    if (!lu.isInvertible()) return fit;
    fit.x = lu.solve(Aty);
    const Eigen::Matrix<double, K, K> inv = lu.inverse();
    std::vector<Eigen::Matrix<double, K, 1>> score(blocks_.size(),
                                                   Eigen::Matrix<double, K, 1>::Zero());
    double sse = 0.0;
    for (const Row& r : rows_) {
      const double e = r.y - r.a.dot(fit.x);
      sse += e * e;
      score[static_cast<size_t>(r.block)] += r.a * e;
    }
    Eigen::Matrix<double, K, K> B = Eigen::Matrix<double, K, K>::Zero();
    for (const auto& s : score) B += s * s.transpose();
    fit.cov_ls = inv * (sse / (fit.rows - K));
    const double g = fit.blocks;
    fit.cov_cluster =
        g > 1 ? Eigen::Matrix<double, K, K>(inv * B * inv * (g / (g - 1.0)))
              : Eigen::Matrix<double, K, K>::Constant(std::numeric_limits<double>::infinity());
    fit.fitted = fit.x.allFinite();
    return fit;
  }

 private:
  struct Row {
    Eigen::Matrix<double, K, 1> a;
    double y;
    int block;
  };
  std::vector<Row> rows_;
  std::map<std::pair<int, int>, int> blocks_;
};

}  // namespace calibd
