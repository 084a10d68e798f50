#pragma once
/// \file
/// The printed face of a board: white board with an AprilTag drawn from the AprilTag library's own
/// family codes (no tag images are shipped), or with a checkerboard.

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/core/common/board.hpp"

namespace calibd::sim {

struct BoardFace {
  BoardGeometry geometry;
  int grid = 0;            ///< tag image side in modules, including the white border (total_width)
  int grid_at_border = 0;  ///< modules across the black square (width_at_border)
  std::vector<uint8_t> bits;  ///< grid*grid, row 0 = top of the upright tag, 1 = white, 0 = black
  float white_albedo = 0.85f;
  float black_albedo = 0.06f;

  /// Builds the face from the geometry's family and tag id (or its checkerboard); false with
  /// `error` when the family is unknown, the id out of range or the pattern off the board.
  bool Build(const BoardGeometry& g, std::string* error);

  /// Albedo at (x, y) in the board frame (metres, x right, y up on the printed side).
  float AlbedoAt(double x_board, double y_board) const;
};

}  // namespace calibd::sim
