#include "calibd/core/lidar/segmentation.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

namespace {

float Horizontal(const RangeImageCell& c) { return std::sqrt(c.x * c.x + c.y * c.y); }
}  // namespace

void RangeSegmenter::Configure(const RangeImage& image, const SegmentationConfig& config) {
  config_ = config;
  tan_ground_ = std::tan(config.ground_angle_deg * kDeg2Rad);
  cos_segmentation_ = static_cast<float>(std::cos(config.segmentation_angle_deg * kDeg2Rad));
  const size_t cells = static_cast<size_t>(image.rows()) * image.cols();
  labels_.assign(cells, kLabelEmpty);
  // Every cell enters the queue once in the first pass and at most once more when its cluster is
  // pruned and segmented again.
  queue_.assign(2 * cells, 0);
  const size_t min_points = static_cast<size_t>(std::max(1, config.min_cluster_points));
  segments_.assign(2 * (cells / min_points) + 2, Segment{});
  row_min_.assign(image.rows(), 0);
  row_max_.assign(image.rows(), 0);
  row_count_.assign(image.rows(), 0);
  row_range_.assign(image.rows(), 0.0f);
  touched_rows_.assign(image.rows(), 0);
  row_thin_.assign(image.rows(), 0);
}

void RangeSegmenter::LabelGround(const RangeImage& image) {
  const int rows = image.rows(), cols = image.cols();
  for (int i = 0; i < rows * cols; ++i)
    labels_[i] = image.cell(i).index >= 0 ? kLabelNone : kLabelEmpty;
  num_ground_ = 0;
  const float tan_ground = static_cast<float>(tan_ground_);
  const float max_step = static_cast<float>(config_.ground_max_step_m);
  // Height of the last ground point, carried over from column to column so that a column whose
  // lowest point is an obstacle can still find the ground behind it.
  float last_ground_z = std::numeric_limits<float>::quiet_NaN();
  for (int col = 0; col < cols; ++col) {
    int prev = -1;
    bool prev_ground = false, first_pair = true;
    for (int row = 0; row < rows; ++row) {
      const int idx = image.CellIndex(row, col);
      if (image.cell(idx).index < 0) continue;
      if (prev < 0) {
        prev = idx;
        continue;
      }
      const RangeImageCell& a = image.cell(prev);
      const RangeImageCell& b = image.cell(idx);
      // Inclination of the segment a-b (Bogoslavskyi §III-B): |dz| against the change of
      // horizontal distance along the column. Going up a column the ground recedes, so the
      // upper point must be the farther one: the lowest row of a board seen against the floor
      // far behind it is nearer and not ground (it made a flat pair with that floor at 7 m).
      const float dxy = Horizontal(b) - Horizontal(a);
      const bool flat = std::fabs(b.z - a.z) <= tan_ground * dxy;
      const bool may_start = prev_ground || first_pair ||
                             (!std::isnan(last_ground_z) && a.z <= last_ground_z + max_step);
      if (flat && may_start) {
        if (labels_[prev] != kLabelGround) {
          labels_[prev] = kLabelGround;
          ++num_ground_;
        }
        labels_[idx] = kLabelGround;
        ++num_ground_;
        last_ground_z = b.z;
        prev_ground = true;
      } else {
        prev_ground = false;
      }
      first_pair = false;
      prev = idx;
    }
  }
}

bool RangeSegmenter::SameObject(const RangeImageCell& a, const RangeImageCell& b) const {
  // beta > threshold <=> cos(beta) < cos(threshold), with cos(beta) = (d1^2 - p1.p2) /
  // (d1 |p1 - p2|) at the farther point p1 (Bogoslavskyi Eq. 1 without trigonometry).
  const RangeImageCell& p1 = a.range >= b.range ? a : b;
  const RangeImageCell& p2 = a.range >= b.range ? b : a;
  // Squared, without the square root (both sides are >= 0 once the left one is; the threshold
  // angle is below 90 deg, so its cosine is positive).
  const float dx = p1.x - p2.x, dy = p1.y - p2.y, dz = p1.z - p2.z;
  const float dist2 = dx * dx + dy * dy + dz * dz;
  if (dist2 <= 0.0f) return true;
  const float dot = p1.x * p2.x + p1.y * p2.y + p1.z * p2.z;
  const float lhs = p1.range * p1.range - dot;
  if (lhs < 0.0f) return true;
  const float rhs = cos_segmentation_ * p1.range;
  return lhs * lhs < rhs * rhs * dist2;
}

int RangeSegmenter::Grow(const RangeImage& image, int seed, int32_t from, int32_t to, int tail) {
  // Breadth-first search with the member array as its queue (no std::queue, no allocation).
  static constexpr int kDr[4] = {-1, 1, 0, 0};
  static constexpr int kDc[4] = {0, 0, -1, 1};
  int head = tail;
  labels_[seed] = to;
  queue_[tail++] = seed;
  while (head < tail) {
    const int cur = queue_[head++];
    const int row = image.RowOf(cur), col = image.ColOf(cur);
    for (int k = 0; k < 4; ++k) {
      const int n = image.NearestCell(row, col, kDr[k], kDc[k], config_.neighbor_search_cells);
      if (n < 0 || labels_[n] != from) continue;
      if (!SameObject(image.cell(cur), image.cell(n))) continue;
      labels_[n] = to;
      queue_[tail++] = n;
    }
  }
  return tail;
}

void RangeSegmenter::Report(int begin, int end, int32_t label) {
  if (end - begin < config_.min_cluster_points) return;
  if (num_segments_ >= static_cast<int>(segments_.size())) return;
  segments_[num_segments_++] = Segment{begin, end, label};
}

int RangeSegmenter::MeasureRows(const RangeImage& image, int begin, int end) {
  const int cols = image.cols();
  const int seed_col = image.ColOf(queue_[begin]);
  int num_touched = 0;
  for (int i = begin; i < end; ++i) {
    const int idx = queue_[i];
    const int row = image.RowOf(idx);
    // Column relative to the seed, unwrapped across the seam of a 360-degree image.
    int dc = image.ColOf(idx) - seed_col;
    if (image.wraps()) {
      if (dc > cols / 2) dc -= cols;
      if (dc < -cols / 2) dc += cols;
    }
    if (row_count_[row] == 0) {
      touched_rows_[num_touched++] = row;
      row_min_[row] = row_max_[row] = dc;
      row_range_[row] = 0.0f;
    }
    row_min_[row] = std::min(row_min_[row], dc);
    row_max_[row] = std::max(row_max_[row], dc);
    row_range_[row] += image.cell(idx).range;
    ++row_count_[row];
  }
  return num_touched;
}

bool RangeSegmenter::MarkThinRows(const RangeImage& image, int num_touched) {
  // A row is thin when it and the rows next to it span less than min_row_width_m together: a
  // post is thin over many rows, while the edge rows of a board, and the sparse bin rows that a
  // MEMS raster crossing the bins at a slant leaves between full ones, have wide neighbours.
  bool any_thin = false;
  const int rows = image.rows();
  for (int k = 0; k < num_touched; ++k) {
    const int row = touched_rows_[k];
    int lo = row_min_[row], hi = row_max_[row], count = 0;
    double range_sum = 0.0;
    for (int r = std::max(0, row - 1); r <= std::min(rows - 1, row + 1); ++r) {
      if (row_count_[r] == 0) continue;
      lo = std::min(lo, row_min_[r]);
      hi = std::max(hi, row_max_[r]);
      range_sum += row_range_[r];
      count += row_count_[r];
    }
    const double width = (hi - lo + 1) * image.azimuth_step_rad() * (range_sum / count);
    row_thin_[row] = width < config_.min_row_width_m;
    any_thin = any_thin || row_thin_[row];
  }
  return any_thin;
}

void RangeSegmenter::PruneAndReport(const RangeImage& image, int begin, int end, int* tail) {
  const int32_t label = labels_[queue_[begin]];
  if (config_.min_row_width_m <= 0.0) {
    Report(begin, end, label);
    return;
  }
  const int num_touched = MeasureRows(image, begin, end);
  const bool any_pruned = MarkThinRows(image, num_touched);
  if (any_pruned) {
    for (int i = begin; i < end; ++i) {
      const int idx = queue_[i];
      if (row_thin_[image.RowOf(idx)]) labels_[idx] = kLabelPruned;
    }
  }
  for (int k = 0; k < num_touched; ++k) {
    row_count_[touched_rows_[k]] = 0;
    row_thin_[touched_rows_[k]] = 0;
  }
  if (!any_pruned) {
    Report(begin, end, label);
    return;
  }
  // Segment what is left again: the pieces no longer touch through the pruned rows.
  for (int i = begin; i < end; ++i) {
    const int idx = queue_[i];
    if (labels_[idx] != label) continue;
    const int piece_begin = *tail;
    const int32_t piece = next_label_++;
    *tail = Grow(image, idx, label, piece, *tail);
    Report(piece_begin, *tail, piece);
  }
}

void RangeSegmenter::Cluster(const RangeImage& image) {
  num_segments_ = 0;
  next_label_ = 1;
  int tail = 0;
  const int cells = image.rows() * image.cols();
  for (int idx = 0; idx < cells; ++idx) {
    if (labels_[idx] != kLabelNone) continue;
    const int begin = tail;
    tail = Grow(image, idx, kLabelNone, next_label_++, tail);
    if (tail - begin >= config_.min_cluster_points) PruneAndReport(image, begin, tail, &tail);
  }
}

}  // namespace calibd
