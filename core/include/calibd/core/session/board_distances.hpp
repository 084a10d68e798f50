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

#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/session/board_observation.hpp"

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
  /// The LiDAR's board centre in the camera's board frame (x, y: in the board's plane), over the
  /// points on the board's plane (not the edges' mixed returns), the points' density evened out
  /// (board_distances.cpp). Symmetric edge bloom leaves it.
  Eigen::Vector2d lidar_in_plane = Eigen::Vector2d::Zero();
  /// The same mean of the unit rays (not renormalised): a range offset b moves that centre by
  /// b mean_ray_area.
  Eigen::Vector3d mean_ray_area = Eigen::Vector3d::Zero();
  /// PnP's distance error grows with the distance over the tag's side in the image: its inverse,
  /// tag side (px) / distance (m), weighs the row so that small far tags do not drown the rest.
  double weight = 0.0;
};

/// Observations with fewer LiDAR points leave no distance.
inline constexpr int kMinBoardDistancePoints = 10;
/// Beyond the board's outline by more than this, a point is not the board's (for the in-plane
/// centroid): above the error a result can have and the beam's bloom at the boards' ranges.
inline constexpr double kCentroidMargin = 0.05;
/// Frames of a board per block of the cluster-robust sigma (consecutive frames of a board share
/// their errors).
inline constexpr int kDistanceBlockFrames = 10;

/// One row per observation of `set` with kMinBoardDistancePoints points or more.
/// With `boards`, the in-plane centroid counts only the points within kCentroidMargin of the
/// board's outline (a person, a stand or a wall beside the board would pull it).
std::vector<BoardDistance> BoardDistances(const ObservationSet& set, const Pose& T_camera_lidar,
                                          const std::vector<BoardGeometry>* boards = nullptr);

/// Weighted least squares y = a . x over rows (already weighted) grouped in blocks of
/// kDistanceBlockFrames frames of a board, with two covariances: the least-squares one from the
/// residuals, and the cluster-robust sandwich over the blocks (Liang & Zeger), which also counts
/// errors shared within a block.
struct DistanceFit {
  bool fitted = false;  ///< more rows than unknowns, and A^T A invertible
  Eigen::VectorXd x;
  Eigen::MatrixXd cov_ls, cov_cluster;
  int rows = 0, blocks = 0;
  /// The larger of the two sigmas of unknown i (the cluster one only over `min_blocks` blocks or
  /// more, fewer being too few to estimate it).
  double Sigma(int i, int min_blocks) const {
    const double ls = cov_ls(i, i);
    const double cluster = blocks >= min_blocks ? cov_cluster(i, i) : 0.0;
    return std::sqrt(std::max(0.0, std::max(ls, cluster)));
  }
};

class DistanceFitter {
 public:
  explicit DistanceFitter(int unknowns) : k_(unknowns) {}

  /// Adds the row a . x = y (a and y weighted by the caller; a has as many entries as unknowns)
  /// of observation `o`.
  void Add(const BoardObservation& o, const Eigen::VectorXd& a, double y) {
    const auto key = std::make_pair(o.board_index, o.frame / kDistanceBlockFrames);
    const int block = blocks_.emplace(key, static_cast<int>(blocks_.size())).first->second;
    rows_.push_back({a, y, block});
  }

  DistanceFit Fit() const {
    DistanceFit fit;
    fit.rows = static_cast<int>(rows_.size());
    fit.blocks = static_cast<int>(blocks_.size());
    if (fit.rows <= k_) return fit;
    Eigen::MatrixXd AtA = Eigen::MatrixXd::Zero(k_, k_);
    Eigen::VectorXd Aty = Eigen::VectorXd::Zero(k_);
    for (const Row& r : rows_) {
      AtA += r.a * r.a.transpose();
      Aty += r.a * r.y;
    }
    const Eigen::FullPivLU<Eigen::MatrixXd> lu(AtA);
    if (!lu.isInvertible()) return fit;
    fit.x = lu.solve(Aty);
    const Eigen::MatrixXd inv = lu.inverse();
    std::vector<Eigen::VectorXd> score(blocks_.size(), Eigen::VectorXd::Zero(k_));
    double sse = 0.0;
    for (const Row& r : rows_) {
      const double e = r.y - r.a.dot(fit.x);
      sse += e * e;
      score[static_cast<size_t>(r.block)] += r.a * e;
    }
    Eigen::MatrixXd B = Eigen::MatrixXd::Zero(k_, k_);
    for (const Eigen::VectorXd& s : score) B += s * s.transpose();
    fit.cov_ls = inv * (sse / (fit.rows - k_));
    const double g = fit.blocks;
    fit.cov_cluster =
        g > 1 ? Eigen::MatrixXd(inv * B * inv * (g / (g - 1.0)))
              : Eigen::MatrixXd::Constant(k_, k_, std::numeric_limits<double>::infinity());
    fit.fitted = fit.x.allFinite();
    return fit;
  }

 private:
  struct Row {
    Eigen::VectorXd a;
    double y;
    int block;
  };
  int k_;
  std::vector<Row> rows_;
  std::map<std::pair<int, int>, int> blocks_;
};

}  // namespace calibd
