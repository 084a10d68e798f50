#include "tag_texture.hpp"

#include <apriltag/apriltag.h>
#include <apriltag/tag16h5.h>
#include <apriltag/tag25h9.h>
#include <apriltag/tag36h10.h>
#include <apriltag/tag36h11.h>
#include <apriltag/tagCircle21h7.h>
#include <apriltag/tagCircle49h12.h>
#include <apriltag/tagCustom48h12.h>
#include <apriltag/tagStandard41h12.h>

#include <cmath>
#include <cstdint>
#include <memory>
#include <sstream>

namespace calibd::sim {

namespace {

struct FamilyEntry {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

// The library's own generated code tables: the texture is whatever the detector decodes, by
// construction, so no tag images are shipped.
constexpr FamilyEntry kFamilies[] = {
    {"tag36h11", tag36h11_create, tag36h11_destroy},
    {"tag36h10", tag36h10_create, tag36h10_destroy},
    {"tag25h9", tag25h9_create, tag25h9_destroy},
    {"tag16h5", tag16h5_create, tag16h5_destroy},
    {"tagStandard41h12", tagStandard41h12_create, tagStandard41h12_destroy},
    {"tagCircle21h7", tagCircle21h7_create, tagCircle21h7_destroy},
    {"tagCircle49h12", tagCircle49h12_create, tagCircle49h12_destroy},
    {"tagCustom48h12", tagCustom48h12_create, tagCustom48h12_destroy},
};

}  // namespace

bool BoardFace::Build(const BoardGeometry& g, std::string* error) {
  std::ostringstream why;
  std::string geometry_error;
  const FamilyEntry* entry = nullptr;
  for (const auto& f : kFamilies) {
    if (g.tag_family == f.name) entry = &f;
  }
  if (!g.IsValid(&geometry_error)) {
    why << geometry_error;
  } else if (entry == nullptr) {
    why << "board " << g.board_id << ": unknown tag_family '" << g.tag_family << "'";
  }
  if (why.tellp() != 0) {
    if (error) *error = why.str();
    return false;
  }

  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> fam(entry->create(),
                                                                       entry->destroy);
  if (g.tag_id >= static_cast<int>(fam->ncodes)) {
    why << "board " << g.board_id << ": tag_id " << g.tag_id << " out of range for " << g.tag_family
        << " (" << fam->ncodes << " codes)";
    if (error) *error = why.str();
    return false;
  }

  // Reversed-border families carry data bits outside the border square, so their whole grid must
  // be printed on the board (BoardGeometry::IsValid only checks the border square). A classic
  // family's outer white ring may run off the board edge: it decodes against any light
  // background.
  if (fam->reversed_border) {
    const double grid_m = g.tag_size_m * fam->total_width / fam->width_at_border;
    if (std::abs(g.tag_offset_m.x()) + grid_m / 2 > g.width_m / 2 + 1e-9 ||
        std::abs(g.tag_offset_m.y()) + grid_m / 2 > g.height_m / 2 + 1e-9) {
      why << "board " << g.board_id << ": the " << g.tag_family << " grid (" << grid_m
          << " m including the outer data bits) does not fit on the board";
      if (error) *error = why.str();
      return false;
    }
  }

  // Same layout as apriltag_to_image() (apriltag.c), decoded here so that no image_u8 (which
  // lives in libapriltag-utils) is needed. Everything starts black.
  const int total = fam->total_width;
  const int at_border = fam->width_at_border;
  std::vector<uint8_t> grid_bits(static_cast<size_t>(total) * static_cast<size_t>(total), 0);
  // One-module white ring: outside the black square for classic families, at the inner edge of
  // the (black-to-white) border for reversed-border families such as tagStandard41h12.
  const int ring_width = at_border + (fam->reversed_border ? 0 : 2);
  const int ring_lo = (total - ring_width) / 2;
  const int ring_hi = ring_lo + ring_width - 1;
  for (int r = ring_lo; r <= ring_hi; ++r) {
    for (int c = ring_lo; c <= ring_hi; ++c) {
      if (r == ring_lo || r == ring_hi || c == ring_lo || c == ring_hi)
        grid_bits[static_cast<size_t>(r * total + c)] = 1;
    }
  }
  // Data bits: bit i (most significant first) at (bit_x, bit_y) relative to the border's
  // top-left module; coordinates are stored unsigned but are negative for bits outside the
  // border (reversed families), as in the library's own unsigned arithmetic.
  const int border_start = (total - at_border) / 2;
  const uint64_t code = fam->codes[g.tag_id];
  for (uint32_t i = 0; i < fam->nbits; ++i) {
    if (((code >> (fam->nbits - i - 1)) & 1u) == 0) continue;
    const int x = static_cast<int32_t>(fam->bit_x[i]) + border_start;
    const int y = static_cast<int32_t>(fam->bit_y[i]) + border_start;
    if (x < 0 || y < 0 || x >= total || y >= total) continue;
    grid_bits[static_cast<size_t>(y * total + x)] = 1;
  }

  geometry = g;
  grid = total;
  grid_at_border = at_border;
  bits = std::move(grid_bits);
  return true;
}

float BoardFace::AlbedoAt(double x_board, double y_board) const {
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
