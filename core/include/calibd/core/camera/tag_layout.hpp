#pragma once
/// \file
/// The printed layout of one AprilTag, from libapriltag's own code tables: what a board carries
/// (the simulator draws it; nothing ships tag images).

#include <cstdint>
#include <string>
#include <vector>

namespace calibd {

struct TagLayout {
  int grid = 0;            ///< modules per side including the white border (total_width)
  int grid_at_border = 0;  ///< modules across the black border square (width_at_border)
  bool reversed_border =
      false;                  ///< data bits lie outside the border square (e.g. tagStandard41h12)
  std::vector<uint8_t> bits;  ///< grid*grid, row 0 = top of the upright tag, 1 = white, 0 = black
};

/// Layout of tag `tag_id` of `family`. False with `error` for an unknown family or an id out of
/// range.
bool MakeTagLayout(const std::string& family, int tag_id, TagLayout* layout, std::string* error);

}  // namespace calibd
