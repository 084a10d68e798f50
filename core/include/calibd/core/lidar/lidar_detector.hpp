#pragma once
/// \file
/// LiDAR marker detection (paper §III-C): range image, ground removal and 4-neighbour BFS
/// segmentation (Bogoslavskyi & Stachniss 2016), per-cluster gates and PCA, the M2DP descriptor
/// (He et al. 2016) and a Pearson-correlation match against reference descriptors of simulated
/// boards. Geometry only: no intensity. All buffers are sized once from the config.
///
/// The stages live in their own modules: range_image.hpp, segmentation.hpp, cluster_pca.hpp,
/// m2dp.hpp and board_references.hpp.

#include <Eigen/Core>
#include <atomic>
#include <memory>
#include <string>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/common/image_view.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/lidar/reference_set.hpp"

namespace calibd {

struct LidarDetectorConfig {
  /// Segmentation (Bogoslavskyi & Stachniss 2016): neighbours belong to one object when the angle
  /// beta between the beam and the line joining them exceeds this. Lower merges more (a board and
  /// the wall behind it); higher splits oblique surfaces into pieces.
  double segmentation_angle_deg = 10.0;
  /// Ground: column-wise, consecutive points whose slope is below this are ground. Higher removes
  /// more of uneven floors, and also of steeply tilted boards (a board is never near this).
  double ground_angle_deg = 10.0;
  /// Ground resumes behind an obstacle when the flat pair lies at most this above the column's last
  /// ground point: keeps flat tops of crates and cars out of the ground.
  double ground_max_step_m = 0.25;
  /// Further points of a range-image cell within this range of its nearest point stay with it:
  /// the descriptor sees the mean of the cell's points, the output all of them; farther ones are
  /// dropped (paper §III-C-1). MEMS patterns put several points in one bin: with one point per
  /// cell a driving M1 loses up to 30% of a board's points at 20 m (8% parked). Higher keeps
  /// edge points blended with the background; 0 keeps one point per cell.
  double cell_range_tolerance_m = 0.1;
  /// Points nearer or farther than this are skipped (counted in invalid_points).
  double min_range_m = 1.0;
  double max_range_m = 60.0;
  /// Empty range-image cells stepped over to find a neighbour: bridges dropouts and the empty bins
  /// of MEMS patterns (Falcon's 0.2 deg lines in 0.075 deg bins). Higher may bridge real gaps.
  int neighbor_search_cells = 3;
  /// Rows of a cluster narrower than this fraction of the smallest board side are pruned (the
  /// board's stand, cables) before the cluster is segmented again. 0 disables.
  double min_row_width_fraction = 0.35;
  /// A cluster refused as a whole (a board joined to the wall behind it, its tripod, the person
  /// holding it, a chair) is split into planar regions, each gated and described like a cluster
  /// (plane_regions.hpp). False describes whole clusters only, as the paper does.
  bool extract_planes = false;
  /// A cell joins a region's plane within this many range-noise sigmas of it; the noise is
  /// estimated from each cluster. Lower splits noisy boards; higher joins what stands close
  /// behind the board.
  double plane_distance_sigmas = 3.0;
  /// An extracted plane is a board only when at most this share of its edge is attached to the
  /// rest of its segment near its plane (PlaneRegion::attached_fraction): hands and stands touch
  /// a board's edge in places; a patch of a wall or of a curved surface is attached all round.
  double max_attached_fraction = 0.5;
  /// With extract_planes: a cluster or plane whose rectangle is too long for a board is cut to the
  /// board-sized window that holds most of its cells (MostPointsWindow) when at most this share
  /// of its cells lie outside it, and gated again: a body or a wall crossing a tilted board's
  /// plane beside it (a person holding it, a board in a corner) leaves a strip within the plane's
  /// noise band that joins the board. A uniform panel that long would already pass the rectangle
  /// gate (max_side_tolerance), so no larger objects get through. 0 disables.
  double max_trimmed_fraction = 0.15;
  // Cheap gates before the descriptor.
  /// Boards stand on stands: a cluster whose lower edge has the ground right below it, within
  /// this height, for at least half its length is an object standing on the floor (crates,
  /// cabinets) and is rejected. The workshop's 0.84 m crates, their bottom taken by the ground,
  /// otherwise pass every gate and score 0.95+ against a 0.6 m board. Boards must then stand
  /// higher than this above the floor; 0 disables.
  double min_board_clearance_m = 0.3;
  int min_cluster_points = 8;  ///< fewer points: too far or too occluded to describe
  /// The smallest rectangle around the cluster in its plane (InPlaneRectangle, independent of how
  /// the board is turned in its plane): its short side at least (1 - tol) x the board's smaller
  /// side - s, s the beam spacing at the cluster's range (sparse far boards look smaller, partial
  /// near ones too). Higher lets more clutter reach the descriptor.
  double extent_tolerance = 0.35;
  /// ... and its long side at most (1 + tol) x the board's larger side + s / 2: the beam footprint
  /// makes far boards look larger (simulated 0.6 m boards at 25-30 m: long side at most 0.69 m
  /// for 99%, 0.75 m at worst; 0.12 lost 4 of 600 OT128 boards), while the workshop's 0.84 m
  /// crates seen whole measure 0.75-0.81 m. Lower rejects far boards; higher lets larger boxes
  /// and panels through.
  double max_side_tolerance = 0.2;
  /// RMS size sqrt(lambda1 + lambda2) of the cluster within [(1 - tol) S - s / 2, (1 + tol) S] of
  /// some configured board, S = sqrt((w^2 + h^2) / 12) that of a full w x h board (independent of
  /// how the board is turned in its plane, unlike the extents). The sharpest cheap gate: on
  /// simulated sweeps boards measure 0.78-1.1 S, crate faces and door parts 1.3-1.9 S.
  double size_tolerance = 0.25;
  /// sqrt(lambda3 / lambda2) of the cluster's PCA. A 0.6 m board with 2 cm range noise measures
  /// 0.07-0.16 (simulated); curved and boxy objects are larger. Scales with the range noise.
  double max_planarity = 0.18;
  /// The cluster's plane normal may be at most this far from horizontal (boards stand roughly
  /// upright; floor patches and box tops lie flat). 90 disables.
  double max_board_tilt_deg = 60.0;
  /// Weigh each row of a cluster by the elevation gap its samples stand for (the gaps to the
  /// neighbouring non-empty rows, averaged over the row) in the PCA and the M2DP counts, so that
  /// a scan pattern's dense and sparse parts count alike (the Falcon's dense band around the
  /// horizon, the OT128's): a board across the band's edge scores higher weighted
  /// (docs/performance-and-reliability.md, "Why the thresholds are where they are"). Costs a few
  /// cell look-ups per cell; false counts every cell once.
  bool weight_by_sample_area = true;
  // M2DP (He et al. 2016): p x q projection planes, l x t bins per plane. He's l = 8, t = 16
  // resolve shapes finely but a sparse cluster (a far board of a few dozen points) spreads its
  // points thinly over the 128 bins of a plane and scores low against its own references. The
  // gates above leave the descriptor to tell boards from board-sized flat pieces, which coarse
  // bins do as well: l = 2, t = 8 raise a sparse LiDAR's recall without false positives
  // (docs/performance-and-reliability.md, "Why the thresholds are where they are").
  int m2dp_elevations = 4;
  int m2dp_azimuths = 16;
  int m2dp_rings = 2;
  int m2dp_sectors = 8;
  /// Larger clusters are subsampled (evenly) to this many points for the descriptor: near boards
  /// have thousands of points and the bin counts only need the shape.
  int max_descriptor_points = 1024;
  // References (paper §III-C-2, Fig. 2b): simulated board clusters for every configured board size
  // seen from DefaultReferenceViews().
  /// Range noise (1 sigma) added to the simulated reference clusters: set it to the sensor's. Real
  /// clusters are noisy across the board plane, and with He's fine M2DP bins noise-free
  /// references describe them badly; with the coarse default bins it changes little
  /// (docs/performance-and-reliability.md, "Why the thresholds are where they are"). 0: noise-free.
  double reference_range_noise_m = 0.02;
  /// Noisy samplings averaged into each reference view, each at another phase of the beam grid
  /// (BoardView::azimuth_phase, elevation_phase) with its own noise: the reference is the mean
  /// (standardized) descriptor, which a single real cluster correlates with better than with any
  /// single sampling. More costs start-up time (400 views x this per board size) for no gain
  /// measured (docs/performance-and-reliability.md, "Why the thresholds are where they are").
  int reference_samples = 4;
  /// Pearson correlation with the best reference (paper Eq. 1); the paper's 0.94. Lower admits
  /// sparser or odder clusters (recall) and board-like clutter (precision); calibd-bench detect
  /// prints the precision/recall curve over thresholds.
  double match_threshold = 0.94;
  // Capacities (fixed memory).
  int max_clusters = 256;       ///< candidates kept per frame
  int max_boards = 16;          ///< board detections per frame
  int max_board_points = 4096;  ///< points kept per detected board
  /// Input points looked at per frame; 0: twice the model's nominal_points_per_frame.
  int max_points = 0;
  /// Report every cluster of at least min_cluster_points with its figures and the gate that
  /// rejected it (LidarDetections::clusters; --debug). Costs a rectangle fit per cluster.
  bool report_clusters = false;

  /// False with `error` naming the bad field.
  bool IsValid(std::string* error) const;
};

/// A cluster that passed the cheap gates, with its best match score (for precision/recall curves).
struct LidarCandidate {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< LiDAR frame, m
  double score = 0.0;  ///< best Pearson correlation with a reference (negative clipped to 0)
  int num_points = 0;  ///< range-image cells (one point each, their mean) described
  Eigen::Vector3d extents = Eigen::Vector3d::Zero();      ///< along the principal axes, m
  double planarity = 0.0;                                 ///< sqrt(lambda3 / lambda2)
  Eigen::Vector3d eigenvalues = Eigen::Vector3d::Zero();  ///< PCA variances, decreasing, m^2
  /// Long and short side of the smallest rectangle around the cluster in its plane, m.
  Eigen::Vector2d rectangle = Eigen::Vector2d::Zero();
};

/// The gate a cluster stopped at (or kBoard when it was detected as a board).
enum class ClusterGate : uint8_t {
  kBoard,
  kTooLarge,    ///< more cells than any board can cover at its range
  kAttached,    ///< a plane whose segment goes on near it along its edge (max_attached_fraction)
  kOnGround,    ///< stands on the floor (min_board_clearance_m)
  kNotPlanar,   ///< max_planarity
  kTilted,      ///< max_board_tilt_deg
  kRectangle,   ///< its in-plane rectangle fits no board (extent_tolerance, max_side_tolerance)
  kSize,        ///< its RMS size fits no board (size_tolerance)
  kDescriptor,  ///< scored below match_threshold
  kCapacity,    ///< beyond max_clusters or max_boards
};
/// "board", "too_large", "attached", "on_ground", "not_planar", "tilted", "rectangle", "size",
/// "descriptor", "capacity".
const char* ClusterGateName(ClusterGate gate);

/// One cluster and where it stopped (LidarDetectorConfig::report_clusters).
struct LidarClusterReport {
  /// LiDAR frame, m (too_large: one of its points; its figures below are not computed)
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();
  int num_points = 0;   ///< range-image cells
  int first_cell = -1;  ///< a cell of the cluster (for pictures)
  int segment = -1;     ///< segment index (labels in the image)
  /// -1: the whole segment; k >= 0: the k-th plane extracted from it (extract_planes)
  int plane = -1;
  /// A plane's share of edge where the segment goes on near it (PlaneRegion); 0 for a segment
  double attached_fraction = 0.0;
  /// Cells cut away as outside the board-sized window (max_trimmed_fraction); its figures are
  /// those of the rest
  int trimmed_cells = 0;
  Eigen::Vector2d rectangle = Eigen::Vector2d::Zero();  ///< long, short side in its plane, m
  double size_m = 0.0;                                  ///< RMS size sqrt(lambda1 + lambda2)
  double planarity = 0.0;                               ///< sqrt(lambda3 / lambda2)
  double tilt_deg = 0.0;                                ///< normal above the horizontal
  double score = 0.0;  ///< descriptor correlation (0 when it stopped before the descriptor)
  ClusterGate gate = ClusterGate::kBoard;
};

/// A detected board cluster.
struct BoardCluster {
  Eigen::Vector3d centroid = Eigen::Vector3d::Zero();  ///< LiDAR frame, m
  Eigen::Vector3d normal = Eigen::Vector3d::Zero();  ///< unit plane normal, pointing at the sensor
  double score = 0.0;
  int num_points = 0;      ///< points stored (<= max_board_points)
  int first_point = 0;     ///< offset into LidarDetections::points / point_indices
  int cluster_points = 0;  ///< points of the whole cluster (stored ones are an even subsample)
};

/// Wall-clock time of each stage of one Detect() (std::chrono::steady_clock), milliseconds.
struct LidarStageTimes {
  double range_image_ms = 0, ground_ms = 0, segmentation_ms = 0, descriptor_ms = 0;
  double total_ms = 0;
};

struct LidarDetections {
  std::vector<BoardCluster> boards;     ///< size = boards found (capacity max_boards)
  std::vector<Eigen::Vector3f> points;  ///< board points, LiDAR frame (capacity max_boards *
                                        ///< max_board_points)
  std::vector<int> point_indices;       ///< index of each stored point in the input cloud
  std::vector<float> point_time_s;      ///< firing time of each stored point after the sweep start,
                                        ///< s (0 when the cloud has no times)
  std::vector<LidarCandidate> candidates;  ///< every gated cluster with its score (capacity
                                           ///< max_clusters)
  /// With report_clusters: every cluster of at least min_cluster_points (capacity max_clusters).
  std::vector<LidarClusterReport> clusters;
  int cloud_points = 0;        ///< points in the input cloud
  int invalid_points = 0;      ///< NaN/inf or out of range, skipped
  int outside_points = 0;      ///< outside the model's field of view, skipped
  int dropped_points = 0;      ///< farther points of a shared range-image cell (paper §III-C-1)
  int chained_points = 0;      ///< further points of a cell kept with it (cell_range_tolerance_m)
  int overflow_points = 0;     ///< beyond max_points, not looked at
  int num_clusters = 0;        ///< segments with >= min_cluster_points
  int dropped_candidates = 0;  ///< gated clusters beyond max_clusters (not scored)
  int dropped_boards = 0;      ///< boards beyond max_boards
  LidarStageTimes times;
};

class LidarDetector {
 public:
  /// Builds the range-image workspace and the reference descriptors (simulated board clusters of
  /// the configured board sizes seen by `model` at several distances and angles). Check ok().
  /// When `cancel` is given and turns true while the references are built, the build stops
  /// early and the detector is not ok() (a daemon stopping during its start-up).
  ///
  /// With `cached` (an earlier detector's references()), its descriptors are taken instead when
  /// they were built from the same config, model and board sizes (ReferenceKey) and a sample of
  /// them, built again now, agrees (a build of other code may describe boards otherwise); the
  /// start-up then costs that sample instead of every reference. Otherwise they are built, and
  /// cache_refusal() says why the cached ones were not taken.
  LidarDetector(const LidarDetectorConfig& config, const LidarModel& model,
                const std::vector<BoardGeometry>& boards, const std::atomic<bool>* cancel = nullptr,
                const LidarReferenceSet* cached = nullptr);
  ~LidarDetector();
  LidarDetector(const LidarDetector&) = delete;
  LidarDetector& operator=(const LidarDetector&) = delete;

  /// The checks of the constructor that cost nothing (the config, the boards, the model), without
  /// building the references: for a caller that builds the detector later, e.g. on a worker
  /// thread, and must refuse a bad config at once. False with `error` naming the field.
  static bool CheckInputs(const LidarDetectorConfig& config, const LidarModel& model,
                          const std::vector<BoardGeometry>& boards, std::string* error);

  /// False when the config, the model or the boards are invalid (error() says which field), or
  /// when no reference board has min_cluster_points points under this model.
  bool ok() const;
  const std::string& error() const;

  /// Detects boards in one sweep. No boards gives an empty result; NaN/inf points are skipped.
  /// Allocates nothing once `out` has been used once or reserved (ReserveOutput). A detector that
  /// is not ok() clears `out`.
  void Detect(const PointCloudView& cloud, LidarDetections* out);
  /// Reserves `out` for any frame (max_boards boards of max_board_points points, max_clusters
  /// candidates), so that its first Detect() does not allocate either: for output buffers made
  /// at start-up (the agent's intake slots).
  void ReserveOutput(LidarDetections* out) const;

  int num_references() const;
  /// The reference descriptors, to keep for the next start (empty when not ok()).
  LidarReferenceSet references() const;
  /// Whether the references came from the `cached` set given to the constructor; if not, and one
  /// was given, why (its key differs, a descriptor built again differs, its shape is wrong).
  bool references_from_cache() const;
  const std::string& cache_refusal() const;
  /// Names everything the references are built from: the descriptor and reference settings of
  /// `config`, the model's scan geometry, the distinct board sizes, the reference views and the
  /// layout version of LidarReferenceSet.
  static uint64_t ReferenceKey(const LidarDetectorConfig& config, const LidarModel& model,
                               const std::vector<BoardGeometry>& boards);

  /// The last Detect()'s range image, and each of its cells' label: segmentation.hpp's
  /// kLabelEmpty, kLabelGround, kLabelPruned, kLabelNone, or the label of a segment, which is
  /// segment_label(LidarClusterReport::segment). For pictures (calibd-calibrate --debug).
  const RangeImage& range_image() const;
  const std::vector<int32_t>& cell_labels() const;
  int32_t segment_label(int segment) const;
  /// Descriptor of a point cluster (LiDAR frame) and its best score against the references, every
  /// point counted once (Detect() describes one mean point per range-image cell, weighed by
  /// weight_by_sample_area). For tests and tuning.
  double ScoreCluster(const std::vector<Eigen::Vector3f>& points);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace calibd
