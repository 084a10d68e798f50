#pragma once
/// \file
/// Square (or rectangular) calibration board carrying an AprilTag or a checkerboard, as
/// configuration. Board frame B: origin at the board centre, x to the right and y up as seen by a
/// viewer facing the printed side, z = x cross y, out of the printed face towards the viewer. The
/// paper's box cost (Eq. 3) bounds |x| <= width/2, |y| <= height/2, |z| <= alpha in this frame.

#include <Eigen/Core>
#include <array>
#include <string>
#include <vector>

namespace calibd {

struct BoardGeometry {
  /// What is printed on the board. The paper (§III-B) uses AprilTags; a checkerboard is the usual
  /// alternative on factory lines.
  enum class PatternKind { kAprilTag, kCheckerboard };

  int board_id = 0;       ///< our id for the board (also the tag id by default)
  double width_m = 0.6;   ///< board extent along x_B
  double height_m = 0.6;  ///< board extent along y_B
  PatternKind pattern = PatternKind::kAprilTag;
  std::string tag_family = "tag36h11";  ///< kAprilTag only
  int tag_id = 0;                       ///< AprilTag id printed on this board (kAprilTag only)
  double tag_size_m = 0.48;  ///< side of the tag's black square (AprilTag's "tag size", kAprilTag)
  /// Centre of the printed pattern (tag or checkerboard) in B (x, y), metres.
  Eigen::Vector2d tag_offset_m{0.0, 0.0};
  /// kCheckerboard only: inner corners (where four squares meet) per row and per column, and the
  /// side of one square. The printed pattern is (checker_inner_cols + 1) x (checker_inner_rows + 1)
  /// squares.
  int checker_inner_rows = 5;
  int checker_inner_cols = 7;
  double checker_square_size_m = 0.06;

  bool IsValid(std::string* error) const;

  /// kAprilTag: the 4 tag corners in B in AprilTag's detection order: bottom-left, bottom-right,
  /// top-right, top-left (counter-clockwise facing the tag, docs/conventions.md#apriltag-order),
  /// z = 0. kCheckerboard: the 4 outermost inner corners in the same order, so that
  /// BoardDetection2D::corners_px always pairs with these points.
  std::array<Eigen::Vector3d, 4> TagCornersInBoard() const;

  /// kCheckerboard: the inner corners in B (z = 0), row-major from the top-left inner corner (rows
  /// run top to bottom, columns left to right as seen facing the print): the order in which
  /// cv::findChessboardCornersSB reports them for an upright board, checker_inner_rows *
  /// checker_inner_cols points. Empty for kAprilTag.
  std::vector<Eigen::Vector3d> CheckerCornersInBoard() const;

  /// The 4 board vertices in B, same order as the tag corners.
  std::array<Eigen::Vector3d, 4> BoardVerticesInBoard() const;
};

}  // namespace calibd
