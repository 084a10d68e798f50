#include "calibd/core/common/board.hpp"

#include <cmath>
#include <sstream>

#include "common/apriltag_families.hpp"

namespace calibd {

bool BoardGeometry::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(width_m > 0.0 && height_m > 0.0 && width_m < 10.0 && height_m < 10.0)) {
    why << "board " << board_id << ": width/height must be in (0, 10) m";
  } else if (pattern == PatternKind::kAprilTag) {
    if (!(tag_size_m > 0.0))
      why << "board " << board_id << ": tag_size must be positive";
    else if (std::abs(tag_offset_m.x()) + tag_size_m / 2 > width_m / 2 + 1e-9 ||
             std::abs(tag_offset_m.y()) + tag_size_m / 2 > height_m / 2 + 1e-9)
      why << "board " << board_id << ": the tag's black square does not fit on the board";
    else if (tag_id < 0)
      why << "board " << board_id << ": tag_id must be >= 0";
    else if (internal::FindAprilTagFamily(tag_family) == nullptr)
      why << "board " << board_id << ": unknown tag_family '" << tag_family
          << "' (tag36h11, tag36h10, tag25h9, tag16h5, tagStandard41h12, tagCircle21h7, "
             "tagCircle49h12, tagCustom48h12)";
  } else if (pattern == PatternKind::kCheckerboard) {
    // Fewer than 2 inner corners along a side gives no grid for findChessboardCornersSB.
    if (checker_inner_rows < 2 || checker_inner_cols < 2)
      why << "board " << board_id << ": checker_inner_rows/checker_inner_cols must be >= 2";
    else if (!(checker_square_size_m > 0.0))
      why << "board " << board_id << ": checker_square_size_m must be positive";
    else if (std::abs(tag_offset_m.x()) + (checker_inner_cols + 1) * checker_square_size_m / 2 >
                 width_m / 2 + 1e-9 ||
             std::abs(tag_offset_m.y()) + (checker_inner_rows + 1) * checker_square_size_m / 2 >
                 height_m / 2 + 1e-9)
      why << "board " << board_id << ": the checkerboard does not fit on the board";
  } else {
    why << "board " << board_id << ": unknown pattern";
  }
  if (why.tellp() == 0) return true;
  if (error) *error = why.str();
  return false;
}

std::array<Eigen::Vector3d, 4> BoardGeometry::TagCornersInBoard() const {
  const double ox = tag_offset_m.x(), oy = tag_offset_m.y();
  double sx = tag_size_m / 2.0, sy = tag_size_m / 2.0;
  if (pattern == PatternKind::kCheckerboard) {
    sx = (checker_inner_cols - 1) * checker_square_size_m / 2.0;
    sy = (checker_inner_rows - 1) * checker_square_size_m / 2.0;
  }
  return {Eigen::Vector3d(ox - sx, oy - sy, 0.0), Eigen::Vector3d(ox + sx, oy - sy, 0.0),
          Eigen::Vector3d(ox + sx, oy + sy, 0.0), Eigen::Vector3d(ox - sx, oy + sy, 0.0)};
}

std::vector<Eigen::Vector3d> BoardGeometry::CheckerCornersInBoard() const {
  std::vector<Eigen::Vector3d> out;
  if (pattern != PatternKind::kCheckerboard || checker_inner_rows < 2 || checker_inner_cols < 2)
    return out;
  out.reserve(static_cast<size_t>(checker_inner_rows) * static_cast<size_t>(checker_inner_cols));
  const double s = checker_square_size_m;
  for (int r = 0; r < checker_inner_rows; ++r) {
    // Row 0 is the top row: the largest y_B (y up in B).
    const double y = tag_offset_m.y() + ((checker_inner_rows - 1) / 2.0 - r) * s;
    for (int c = 0; c < checker_inner_cols; ++c) {
      const double x = tag_offset_m.x() + (c - (checker_inner_cols - 1) / 2.0) * s;
      out.emplace_back(x, y, 0.0);
    }
  }
  return out;
}

std::array<Eigen::Vector3d, 4> BoardGeometry::BoardVerticesInBoard() const {
  const double w = width_m / 2.0, h = height_m / 2.0;
  return {Eigen::Vector3d(-w, -h, 0.0), Eigen::Vector3d(w, -h, 0.0), Eigen::Vector3d(w, h, 0.0),
          Eigen::Vector3d(-w, h, 0.0)};
}

}  // namespace calibd
