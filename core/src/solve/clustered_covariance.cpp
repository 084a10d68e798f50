#include "calibd/core/solve/clustered_covariance.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <map>

#include "calibd/core/common/stats.hpp"

namespace calibd {

namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

// M_C of one clustering: cluster_of[k] is observation k's cluster in [0, clusters).
Matrix6d ClusterMeat(const std::vector<ObservationScore>& scores,
                     const std::vector<int>& cluster_of, int clusters) {
  std::vector<Vector6d> sums(static_cast<size_t>(clusters), Vector6d::Zero());
  for (size_t k = 0; k < scores.size(); ++k)
    sums[static_cast<size_t>(cluster_of[k])] += scores[k].score;
  Matrix6d meat = Matrix6d::Zero();
  for (const Vector6d& s : sums) meat.noalias() += s * s.transpose();
  return meat * (static_cast<double>(clusters) / static_cast<double>(clusters - 1));
}

// Dense cluster indices of `keys` (in order of first appearance), and how many.
int Clusters(const std::vector<int>& keys, std::vector<int>* cluster_of) {
  std::map<int, int> index;
  cluster_of->resize(keys.size());
  for (size_t k = 0; k < keys.size(); ++k)
    (*cluster_of)[k] = index.emplace(keys[k], static_cast<int>(index.size())).first->second;
  return static_cast<int>(index.size());
}

}  // namespace

ClusteredCovariance ClusterRobustCovariance(const Matrix6d& information,
                                            const std::vector<ObservationScore>& scores,
                                            int stretches) {
  ClusteredCovariance out;
  const Eigen::FullPivLU<Matrix6d> lu(information);
  if (!lu.isInvertible() || scores.empty() || stretches < 2) return out;

  // Stretches: the distinct frames in order, cut into runs of about equal count.
  std::vector<int> frame_of(scores.size()), board_key(scores.size());
  for (size_t k = 0; k < scores.size(); ++k) {
    frame_of[k] = scores[k].frame;
    board_key[k] = scores[k].board;
  }
  const std::vector<int> stretch_key = FrameStretches(frame_of, stretches);
  std::vector<int> stretch_of, board_of;
  out.stretches = Clusters(stretch_key, &stretch_of);
  out.boards = Clusters(board_key, &board_of);
  if (out.stretches < 2) return out;

  Matrix6d meat = ClusterMeat(scores, stretch_of, out.stretches);
  if (out.boards >= 2) meat += ClusterMeat(scores, board_of, out.boards);
  const Matrix6d bread = lu.inverse();
  out.covariance = bread * meat * bread.transpose();
  out.covariance = 0.5 * (out.covariance + out.covariance.transpose());
  out.valid = true;
  return out;
}

}  // namespace calibd
