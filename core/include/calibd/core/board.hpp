#pragma once
/// \file
/// Square (or rectangular) calibration board carrying an AprilTag, as configuration.
/// Board frame B: origin at the board centre, x to the right and y up as seen by a viewer facing
/// the printed side, z = x cross y, out of the printed face towards the viewer. The paper's box
/// cost (Eq. 3) bounds |x| <= width/2, |y| <= height/2, |z| <= alpha in this frame.

#include <Eigen/Core>
#include <array>
#include <string>

namespace calibd {

struct BoardGeometry {
  int board_id = 0;       ///< our id for the board (also the tag id by default)
  double width_m = 0.6;   ///< board extent along x_B
  double height_m = 0.6;  ///< board extent along y_B
  std::string tag_family = "tag36h11";
  int tag_id = 0;            ///< AprilTag id printed on this board
  double tag_size_m = 0.48;  ///< side of the tag's black square (AprilTag's "tag size")
  Eigen::Vector2d tag_offset_m{0.0, 0.0};  ///< tag centre in B (x, y), metres

  bool IsValid(std::string* error) const;

  /// The 4 tag corners in B in AprilTag's detection order: bottom-left, bottom-right, top-right,
  /// top-left (counter-clockwise facing the tag, docs/conventions.md#apriltag-order), z = 0.
  std::array<Eigen::Vector3d, 4> TagCornersInBoard() const;

  /// The 4 board vertices in B, same order as the tag corners.
  std::array<Eigen::Vector3d, 4> BoardVerticesInBoard() const;
};

}  // namespace calibd
