#pragma once
/// \file
/// Coarse grid search (paper §III-D, Alg. 1): roll/pitch/yaw perturbations of the prior extrinsic,
/// each scored by the number of LiDAR board points inside a range-image region of interest around
/// every camera-detected board centre mapped into the LiDAR frame. The best candidate also yields
/// the camera-LiDAR board correspondences for the optimisation.
///
/// Alg. 1's region is a cube around the predicted board centre; its range-image rectangle also
/// holds whatever lies in front of or behind the board in that direction (a wall 2 m behind, a
/// cabinet face). A cluster counts only when its mean range is within the cube's reach of the
/// predicted centre's (a board side, plus 5% of the range for the camera's depth error).
///
/// Beyond the paper: a second, finer pass around the best coarse candidate, and an explicit
/// "no candidate" result when even the best one sees too few points (instead of a silent guess).

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/board_observation.hpp"
#include "calibd/core/session/session_observations.hpp"

namespace calibd {

/// Added to the camera's view cone of the point-fraction gate: a board's angular radius at the
/// closest range a workshop uses (a 1 m board at 1.5 m is about 18 deg) and the prior's error
/// beyond the search's reach that still leaves a board's edge inside.
inline constexpr double kViewConeMarginDeg = 20.0;

struct GridSearchConfig {
  double range_deg = 9.0;  ///< perturbations in [-range, +range] on roll, pitch and yaw (paper: 9)
  double step_deg = 1.5;   ///< paper: 1.5
  bool refine = true;      ///< second pass around the best candidate
  double refine_range_deg = 1.0;
  double refine_step_deg = 0.5;  ///< enough to land in the optimiser's basin (about 1 deg wide)
  /// The best candidate must put at least this many LiDAR board points in the regions, and at
  /// least min_point_fraction of the clustered points the camera could have seen: those of frames
  /// with a camera board, in clusters within the camera's view cone (the widest board direction
  /// from its axis under the prior, widened by the search's reach and kViewConeMarginDeg).
  /// Otherwise the result is kNoCandidate. A 360 deg LiDAR's clusters behind the camera do not
  /// count.
  int min_points = 30;
  double min_point_fraction = 0.2;
  /// Candidates are scored on at most this many frame pairs, evenly spaced over the session (the
  /// coarse alignment needs a spread of views, not every frame); correspondences for every frame
  /// are then taken with the winner. 0 scores every frame.
  int max_scoring_frames = 24;

  bool IsValid(std::string* error) const;
};

struct GridSearchResult {
  enum class Status { kOk, kNoCandidate, kNoInput } status = Status::kNoInput;
  std::string reason;
  Pose T_camera_lidar = Pose::Identity();
  Eigen::Vector3d perturbation_rpy_deg = Eigen::Vector3d::Zero();  ///< of the best, LiDAR axes
  long best_count = 0;    ///< points in the regions for the best candidate
  long prior_count = 0;   ///< the same for the unperturbed prior
  long total_points = 0;  ///< clustered LiDAR points the camera could have seen (see above)
  int candidates = 0;     ///< candidates scored (both passes)
  double search_ms = 0.0;
};

/// Perturbed extrinsic of a candidate: R = R_prior * R(roll, pitch, yaw) with the angles about
/// the LiDAR's own axes (x forward: well conditioned, unlike T_camera_lidar's own Euler angles
/// near pitch = -90 deg, docs/conventions.md#euler); the LiDAR origin keeps its camera position.
Pose PerturbExtrinsic(const Pose& T_camera_lidar, const Eigen::Vector3d& rpy_rad);

/// Whether frame `frame` of `num_frames` is among `max_frames` picked evenly over them (all when
/// max_frames is 0 or >= num_frames): exactly min(num_frames, max_frames) frames are picked.
inline bool SpreadFrameSelected(int frame, int num_frames, int max_frames) {
  if (max_frames <= 0 || max_frames >= num_frames) return true;
  const auto m = static_cast<int64_t>(max_frames);
  return (static_cast<int64_t>(frame) + 1) * m / num_frames >
         static_cast<int64_t>(frame) * m / num_frames;
}

/// The rank of `frame` among the frames SpreadFrameSelected picks (0, 1, ...), -1 when it is
/// not picked.
inline int SpreadFrameRank(int frame, int num_frames, int max_frames) {
  if (max_frames <= 0 || max_frames >= num_frames) return frame;
  if (!SpreadFrameSelected(frame, num_frames, max_frames)) return -1;
  return static_cast<int>((static_cast<int64_t>(frame) + 1) * max_frames / num_frames - 1);
}

class GridSearch {
 public:
  /// `projection` must be configured for the session's LiDAR model (its CellOf is used).
  GridSearch(const GridSearchConfig& config, const RangeImage& projection,
             const std::vector<BoardGeometry>& boards);

  /// Runs both passes over `session`. When the result is kOk and `correspondences` is non-null,
  /// it receives one observation per camera board matched to the LiDAR cluster with the most
  /// points in its region (each cluster used once). Only `max_frames` frame pairs spread evenly
  /// over the session take part, in the search and in the correspondences (0: every frame; see
  /// SpreadFrameSelected): its memory and time do not grow with a longer session. The candidates
  /// are counted on `threads` threads; the result does not depend on how many.
  GridSearchResult Run(const SessionObservations& session, const Pose& T_camera_lidar_prior,
                       ObservationSet* correspondences, int max_frames = 0, int threads = 1);

  /// Points of `session` inside the regions for one extrinsic, by brute force over every point
  /// (an oracle for tests; Run uses per-cluster integral images).
  long CountBruteForce(const SessionObservations& session, const Pose& T_camera_lidar) const;
  /// The fast count Run uses, over the integral images of the last Run's session (for tests).
  long CountForTest(const SessionObservations& session, const Pose& T_camera_lidar) const {
    return CountFast(session, T_camera_lidar, nullptr);
  }

 private:
  struct Roi {
    int row_lo, row_hi, col_lo, col_hi;
  };
  struct ClusterGrid {  // integral image of a cluster's points over its cell bounding box
    int frame, row0, col0, rows, cols;
    size_t offset;             // into integral_
    double range_m;            // mean range of its points
    Eigen::Vector3d centroid;  // mean of its points, LiDAR frame
  };
  bool RegionOf(const Eigen::Vector3d& centre_lidar, double side, Roi* roi) const;
  /// The region of one camera-detected board under T_lidar_camera, and the range band
  /// [range_lo, range_hi] a cluster's mean range must fall in; false when there is none.
  bool BoardRegion(const SessionObservations::CameraBoard& cam, const Pose& T_lidar_camera,
                   Roi* roi, double* range_lo, double* range_hi) const;
  /// Mean range of a cluster's points.
  static double ClusterRange(const SessionObservations& session,
                             const SessionObservations::LidarCluster& cluster);
  /// Points of the clusters the camera could have seen (GridSearchConfig::min_points), over the
  /// frames taking part.
  long InViewPoints(const SessionObservations& session, const Pose& T_camera_lidar_prior);
  long CountFast(const SessionObservations& session, const Pose& T_camera_lidar,
                 std::vector<int>* best_cluster, int frame_stride = 1) const;
  long ClusterCount(const ClusterGrid& g, const Roi& roi) const;
  /// Integral images of the clusters of the frames taking part (max_frames_).
  void Prepare(const SessionObservations& session);
  int Rank(int frame, int num_frames) const {
    return SpreadFrameRank(frame, num_frames, max_frames_);
  }

  GridSearchConfig config_;
  const RangeImage& projection_;
  std::vector<BoardGeometry> boards_;
  std::vector<ClusterGrid> grids_;          // one per session cluster
  std::vector<int32_t> integral_;           // all clusters' integral images
  std::vector<int> frame_first_cluster_;    // per frame: first index into grids_ (size frames + 1)
  std::vector<std::pair<int, int>> cells_;  // Prepare's scratch: one cluster's cells
  std::vector<char> frame_has_board_;       // InViewPoints' scratch: per frame
  int max_frames_ = 0;                      // of the current Run
};

}  // namespace calibd
