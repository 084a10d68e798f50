#include "tag_texture.hpp"

#include "calibd/core/camera/tag_layout.hpp"

#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>

namespace calibd::sim {

bool BoardFace::Build(const BoardGeometry& g, std::string* error) {
  std::string why;
  if (g.pattern == BoardGeometry::PatternKind::kCheckerboard) {
    if (!g.IsValid(&why)) {
      if (error) *error = "board " + std::to_string(g.board_id) + ": " + why;
      return false;
    }
    geometry = g;
    grid = grid_at_border = 0;
    bits.clear();
    return true;
  }
  TagLayout layout;
  if (!g.IsValid(&why) || !MakeTagLayout(g.tag_family, g.tag_id, &layout, &why)) {
    if (error) *error = "board " + std::to_string(g.board_id) + ": " + why;
    return false;
  }
  // Reversed-border families carry data bits outside the border square, so their whole grid must
  // be printed on the board (BoardGeometry::IsValid only checks the border square). A classic
  // family's outer white ring may run off the board edge: it decodes against any light
  // background.
  if (layout.reversed_border) {
    const double grid_m = g.tag_size_m * layout.grid / layout.grid_at_border;
    if (std::abs(g.tag_offset_m.x()) + grid_m / 2 > g.width_m / 2 + 1e-9 ||
        std::abs(g.tag_offset_m.y()) + grid_m / 2 > g.height_m / 2 + 1e-9) {
      std::ostringstream m;
      m << "board " << g.board_id << ": the " << g.tag_family << " grid (" << grid_m
        << " m including the outer data bits) does not fit on the board";
      if (error) *error = m.str();
      return false;
    }
  }
  geometry = g;
  grid = layout.grid;
  grid_at_border = layout.grid_at_border;
  bits = std::move(layout.bits);
  return true;
}

float BoardFace::AlbedoAt(double x_board, double y_board) const {
  if (geometry.pattern == BoardGeometry::PatternKind::kCheckerboard) {
    // (inner_cols + 1) x (inner_rows + 1) squares centred on tag_offset_m; square (i, j) counted
    // from the top-left, which is black (BoardGeometry::CheckerCornersInBoard's order).
    const double s = geometry.checker_square_size_m;
    const double half_w = (geometry.checker_inner_cols + 1) * s / 2.0;
    const double half_h = (geometry.checker_inner_rows + 1) * s / 2.0;
    const double x = x_board - geometry.tag_offset_m.x(), y = y_board - geometry.tag_offset_m.y();
    if (!(std::abs(x) < half_w && std::abs(y) < half_h)) return white_albedo;
    const int i = static_cast<int>(std::floor((half_h - y) / s));
    const int j = static_cast<int>(std::floor((x + half_w) / s));
    return (i + j) % 2 == 0 ? black_albedo : white_albedo;
  }
  if (grid <= 0) return white_albedo;
  // The black square (width_at_border modules) is geometry.tag_size_m wide and centred on
  // tag_offset_m; the whole grid shares that centre. Row 0 is the top of the upright tag, so
  // rows grow against y_B (board.hpp: y up on the printed side).
  const double module = geometry.tag_size_m / grid_at_border;
  const double half = 0.5 * grid;
  const double col_f = (x_board - geometry.tag_offset_m.x()) / module + half;
  const double row_f = half - (y_board - geometry.tag_offset_m.y()) / module;
  if (!(col_f >= 0.0 && row_f >= 0.0 && col_f < grid && row_f < grid)) return white_albedo;
  const int col = static_cast<int>(col_f);
  const int row = static_cast<int>(row_f);
  return bits[static_cast<size_t>(row * grid + col)] ? white_albedo : black_albedo;
}

}  // namespace calibd::sim
