#pragma once
/// \file
/// Ground removal and object segmentation on a range image (paper §III-C-1, after Bogoslavskyi &
/// Stachniss 2016, "Fast range image-based segmentation of sparse 3D laser scans").
///
/// - Ground (Bogoslavskyi §III-B, simplified): each column is walked upwards from its lowest
///   point. A pair of consecutive points whose connecting segment recedes from the sensor and is
///   inclined less than `ground_angle_deg` from the horizontal is ground when it starts at the
///   column's lowest point or continues a ground run, or resumes ground behind an obstacle at most
///   `ground_max_step_m` above the last ground point of the column. Flat surfaces well above the
///   ground (crate tops) are not ground.
/// - Segmentation (Bogoslavskyi §III-C): 4-neighbour breadth-first search over non-ground cells.
///   Two neighbours belong to one object when beta = atan2(d2 sin psi, d1 - d2 cos psi) exceeds
///   `segmentation_angle_deg` (d1 >= d2 their ranges, psi the angle between their beams). psi is
///   taken from the two points themselves rather than from the nominal grid steps, which is the
///   same for grid sensors and exact for MEMS patterns whose points wander within their bins.
///   Neighbours are the nearest non-empty cells within `neighbor_search_cells` steps, so dropouts
///   and the empty bins of MEMS patterns do not split objects. Columns wrap for 360-degree
///   sensors.
/// - Thin-part pruning (ours): a board touches its stand, and the angle criterion cannot separate
///   two touching surfaces. Rows of a cluster that span less than `min_row_width_m` together with
///   the rows next to them (a post, a cable) are removed and the rest is segmented again, so the
///   board comes out on its own (with at most one row of the post).
///
/// All buffers are allocated by Configure(); Run() allocates nothing.

#include <cstdint>
#include <vector>

#include "calibd/core/lidar/range_image.hpp"

namespace calibd {

struct SegmentationConfig {
  double ground_angle_deg = 10.0;        ///< steeper steps are not ground
  double ground_max_step_m = 0.25;       ///< ground resumes behind obstacles within this height
  double segmentation_angle_deg = 10.0;  ///< beta threshold; lower merges more
  int neighbor_search_cells = 3;         ///< empty cells stepped over to find a neighbour
  int min_cluster_points = 8;            ///< smaller clusters are not reported
  double min_row_width_m = 0.2;          ///< narrower rows of a cluster are pruned (0: never)
};

/// Cell labels.
enum : int32_t {
  kLabelEmpty = -1,
  kLabelGround = -2,
  kLabelPruned = -3,  ///< removed as a thin part of a cluster
  kLabelNone = 0,     ///< not yet labelled; clusters are 1, 2, ...
};

/// A reported cluster: cells members()[begin, end) of the range image.
struct Segment {
  int begin = 0;
  int end = 0;
  int32_t label = 0;
  int size() const { return end - begin; }
};

class RangeSegmenter {
 public:
  /// Sizes the buffers for `image`'s grid.
  void Configure(const RangeImage& image, const SegmentationConfig& config);

  /// Labels ground cells (clears all labels first).
  void LabelGround(const RangeImage& image);
  /// Segments the non-ground cells into clusters; reports those with >= min_cluster_points.
  void Cluster(const RangeImage& image);

  const std::vector<int32_t>& labels() const { return labels_; }
  int num_segments() const { return num_segments_; }
  const Segment& segment(int i) const { return segments_[i]; }
  const int32_t* members() const { return queue_.data(); }
  int num_ground_cells() const { return num_ground_; }
  int num_clusters() const { return next_label_ - 1; }  ///< all clusters, small ones included

 private:
  bool SameObject(const RangeImageCell& a, const RangeImageCell& b) const;
  /// Grows the cluster of `seed` over cells labelled `from`, labelling them `to`; appends the
  /// cells to the queue and returns the end of the appended range.
  int Grow(const RangeImage& image, int seed, int32_t from, int32_t to, int tail);
  /// Prunes thin rows of cluster [begin, end) and reports its remaining pieces.
  void PruneAndReport(const RangeImage& image, int begin, int end, int* tail);
  /// PruneAndReport's steps: each row's column span and range sum over the segment queue_[begin,
  /// end) (returns the rows touched, in touched_rows_), then which rows are thin (row_thin_; true
  /// when any is).
  int MeasureRows(const RangeImage& image, int begin, int end);
  bool MarkThinRows(const RangeImage& image, int num_touched);
  void Report(int begin, int end, int32_t label);

  SegmentationConfig config_;
  double tan_ground_ = 0.0;
  float cos_segmentation_ = 0.0f;
  std::vector<int32_t> labels_;    // per cell
  std::vector<int32_t> queue_;     // BFS queue and cluster membership, 2 x cells
  std::vector<Segment> segments_;  // capacity: cells / min_cluster_points
  int num_segments_ = 0;
  int next_label_ = 1;
  int num_ground_ = 0;
  // Per-row scratch of the pruning step.
  std::vector<int> row_min_, row_max_, row_count_;
  std::vector<float> row_range_;
  std::vector<int> touched_rows_;
  std::vector<char> row_thin_;
};

}  // namespace calibd
