#include "calibd/core/board.hpp"

#include <cmath>
#include <sstream>

namespace calibd {

bool BoardGeometry::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(width_m > 0.0 && height_m > 0.0 && width_m < 10.0 && height_m < 10.0))
    why << "board " << board_id << ": width/height must be in (0, 10) m";
  else if (!(tag_size_m > 0.0))
    why << "board " << board_id << ": tag_size must be positive";
  else if (std::abs(tag_offset_m.x()) + tag_size_m / 2 > width_m / 2 + 1e-9 ||
           std::abs(tag_offset_m.y()) + tag_size_m / 2 > height_m / 2 + 1e-9)
    why << "board " << board_id << ": the tag's black square does not fit on the board";
  else if (tag_id < 0)
    why << "board " << board_id << ": tag_id must be >= 0";
  else if (tag_family.empty())
    why << "board " << board_id << ": tag_family is empty";
  if (why.tellp() == 0) return true;
  if (error) *error = why.str();
  return false;
}

std::array<Eigen::Vector3d, 4> BoardGeometry::TagCornersInBoard() const {
  const double s = tag_size_m / 2.0;
  const double ox = tag_offset_m.x(), oy = tag_offset_m.y();
  return {Eigen::Vector3d(ox - s, oy - s, 0.0), Eigen::Vector3d(ox + s, oy - s, 0.0),
          Eigen::Vector3d(ox + s, oy + s, 0.0), Eigen::Vector3d(ox - s, oy + s, 0.0)};
}

std::array<Eigen::Vector3d, 4> BoardGeometry::BoardVerticesInBoard() const {
  const double w = width_m / 2.0, h = height_m / 2.0;
  return {Eigen::Vector3d(-w, -h, 0.0), Eigen::Vector3d(w, -h, 0.0), Eigen::Vector3d(w, h, 0.0),
          Eigen::Vector3d(-w, h, 0.0)};
}

}  // namespace calibd
