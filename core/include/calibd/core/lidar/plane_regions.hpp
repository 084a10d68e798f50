#pragma once
/// \file
/// Planar regions inside one cluster of a range image: the board cut out of whatever the
/// segmentation joined it to (ours, after the paper's advice to describe boards, not objects).
///
/// The Bogoslavskyi angle criterion cannot split surfaces whose samples are far apart: with a
/// 16-ring LiDAR's 2 deg between rings, a board's top ring and a wall half a metre behind it pass
/// as one object, and a tripod, a person holding the board or a chair joins the board to the
/// room. Inside such a cluster the board is still a plane, apart from its surroundings:
/// 1. Cells get a local plane (about `seeds_per_board` on any board-sized area): the PCA of
///    the cluster's cells in a window around it, `window_half_m` or
///    one beam spacing each way (wider where the pattern leaves cells empty). Its RMS residual
///    is the cell's flatness.
/// 2. The range noise is estimated from the data: the median flatness over the cluster (most of
///    any scene is locally planar), so the tolerance below follows the sensor.
/// 3. Regions grow from the flattest unassigned cell: a 4-neighbour (range_image.hpp
///    NearestCell) joins when it lies within `distance_sigmas` noise sigmas of the region's plane,
///    refitted as the region doubles. A surface behind the board, a post or a body is off the
///    plane; edge cells, whose windows mix surfaces, join by their distance alone. Rows narrower
///    than `min_row_width_m` are then cut off, as the segmentation does (a post close behind
///    the board's plane, an arm).
/// 4. Each region's edge is classified: free (nothing beyond it, or a step to another surface) or
///    attached (the cluster goes on near the plane). Patches of larger surfaces are attached.
///
/// All buffers are allocated by Configure(); Extract() allocates nothing.

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "calibd/core/lidar/range_image.hpp"

namespace calibd {

struct PlaneRegionConfig {
  /// Half extent of the window of a local plane (m, at least one beam spacing): a quarter of the
  /// smallest board side fits inside the board and spans several noise sigmas.
  double window_half_m = 0.15;
  /// Rows of a region narrower than this are cut off (a post or an arm on the board's plane).
  double min_row_width_m = 0.2;
  double distance_sigmas = 3.0;   ///< a cell joins a plane within this many noise sigmas of it
  double min_distance_m = 0.01;   ///< floor of that tolerance (noise-free data)
  int neighbor_search_cells = 3;  ///< empty cells stepped over to find a neighbour
  int min_region_cells = 8;       ///< smaller regions are not reported
  /// Local planes (seeds and noise samples) on about `seeds_per_board` cells of an area of
  /// `min_board_area_m2` at each cell's range; 0: on every cell.
  double min_board_area_m2 = 0.0;
  int seeds_per_board = 64;
};

/// A region: entries members()[begin, end) of the cluster's cell list.
struct PlaneRegion {
  int begin = 0;
  int end = 0;
  Eigen::Vector3f normal = Eigen::Vector3f::UnitX();  ///< its plane, LiDAR frame
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  int32_t label = 0;  ///< its cells' label in the extraction
  int size() const { return end - begin; }
};

class PlaneRegions {
 public:
  /// Sizes the buffers for `image`'s grid.
  void Configure(const RangeImage& image, const PlaneRegionConfig& config);

  /// Splits a cluster of `n` range-image cells `cells` (one point each, `points`, LiDAR frame)
  /// into planar regions; returns how many were reported.
  int Extract(const RangeImage& image, const int32_t* cells, const Eigen::Vector3f* points, int n);

  int num_regions() const { return num_regions_; }
  const PlaneRegion& region(int i) const { return regions_[i]; }
  /// Positions k in the cluster's cell list (0 <= k < n), grouped by region.
  const int32_t* members() const { return members_.data(); }
  /// Per range-image cell: i + 1 for the cells of reported region i of the last Extract(), 0 for
  /// every other cell.
  const std::vector<int32_t>& cell_region() const { return cell_region_; }
  /// Share of region i's edge (cell sides towards cells outside it) where the cluster goes on
  /// near its plane: a wall cut into patches, a surface bending away. A board's edge is free
  /// (nothing, or a step to what is behind it) but where a hand or a stand touches it. `points`
  /// as given to Extract().
  double AttachedFraction(const RangeImage& image, const Eigen::Vector3f* points, int i) const;
  /// The range noise (1 sigma, m) estimated in the last Extract(); 0 when no cell had a plane.
  double noise_m() const { return noise_m_; }

 private:
  /// Every how many cells of the cluster a local plane is fitted around `cell`.
  int SeedStride(const RangeImage& image, int32_t cell) const;
  /// Local plane at range-image cell `cell` of the cluster; false when its window has too few
  /// cells of the cluster.
  bool LocalPlane(const RangeImage& image, const Eigen::Vector3f* points, int32_t cell,
                  Eigen::Vector3f* normal, Eigen::Vector3f* center, float* flatness) const;
  /// Grows the region of seed `k` into members_ from `tail`, labelling its cells `label`; fills
  /// `region`'s end and plane and returns the end.
  int Grow(const RangeImage& image, const Eigen::Vector3f* points, int k, int32_t label, int tail,
           float tolerance, PlaneRegion* region);

  /// Gives cluster position k back to later regions (a thin row, a region too small), but never
  /// as a seed: a fragment does not cut the plane it lies on.
  void Release(int32_t k) {
    region_of_[k] = 0;
    released_[k] = 1;
  }
  /// Cuts the rows narrower than min_row_width_m off `region` (compacting members_); returns its
  /// new end.
  int PruneThinRows(const RangeImage& image, const PlaneRegion& region);

  PlaneRegionConfig config_;
  std::vector<int> row_min_, row_max_, row_cols_, touched_rows_;  // per image row
  std::vector<int32_t> local_;        // per image cell: its position in the cluster, or -1
  std::vector<int32_t> cell_region_;  // per image cell, see cell_region()
  std::vector<int32_t> cells_;        // the last cluster's cells (to clear the two above)
  int num_cells_ = 0;
  // Per cluster position.
  std::vector<Eigen::Vector3f> normals_, centers_;  // local planes
  std::vector<float> flatness_;     // RMS residual of the local plane, < 0 without one
  std::vector<float> sorted_;       // scratch for the noise quantile
  std::vector<int32_t> seeds_;      // positions with a local plane, flattest first
  std::vector<int32_t> region_of_;  // 0 unassigned, else the region's label
  std::vector<char> released_;      // see Release()
  std::vector<int32_t> members_;
  std::vector<PlaneRegion> regions_;
  int num_regions_ = 0;
  double noise_m_ = 0.0;
  float tolerance_ = 0.0f;  // of the last Extract()
};

}  // namespace calibd
