#include "calibd/core/camera/tag_layout.hpp"

#include <memory>

#include "common/apriltag_families.hpp"

namespace calibd {

bool MakeTagLayout(const std::string& family, int tag_id, TagLayout* layout, std::string* error) {
  const internal::AprilTagFamilyEntry* entry = internal::FindAprilTagFamily(family);
  if (entry == nullptr) {
    if (error) *error = "unknown tag family '" + family + "'";
    return false;
  }
  std::unique_ptr<apriltag_family_t, void (*)(apriltag_family_t*)> fam(entry->create(),
                                                                       entry->destroy);
  if (tag_id < 0 || tag_id >= static_cast<int>(fam->ncodes)) {
    if (error)
      *error = "tag_id " + std::to_string(tag_id) + " out of range for " + family + " (" +
               std::to_string(fam->ncodes) + " codes)";
    return false;
  }
  // Same layout as apriltag_to_image() (apriltag.c), decoded here so that no image_u8 (which
  // lives in libapriltag-utils) is needed. Everything starts black.
  const int total = fam->total_width;
  const int at_border = fam->width_at_border;
  std::vector<uint8_t> bits(static_cast<size_t>(total) * static_cast<size_t>(total), 0);
  // One-module white ring: outside the black square for classic families, at the inner edge of
  // the (black-to-white) border for reversed-border families such as tagStandard41h12.
  const int ring_width = at_border + (fam->reversed_border ? 0 : 2);
  const int ring_lo = (total - ring_width) / 2;
  const int ring_hi = ring_lo + ring_width - 1;
  for (int r = ring_lo; r <= ring_hi; ++r)
    for (int c = ring_lo; c <= ring_hi; ++c)
      if (r == ring_lo || r == ring_hi || c == ring_lo || c == ring_hi)
        bits[static_cast<size_t>(r * total + c)] = 1;
  // Data bits: bit i (most significant first) at (bit_x, bit_y) relative to the border's
  // top-left module; coordinates are stored unsigned but are negative for bits outside the
  // border (reversed families), as in the library's own unsigned arithmetic.
  const int border_start = (total - at_border) / 2;
  const uint64_t code = fam->codes[tag_id];
  for (uint32_t i = 0; i < fam->nbits; ++i) {
    if (((code >> (fam->nbits - i - 1)) & 1u) == 0) continue;
    const int x = static_cast<int32_t>(fam->bit_x[i]) + border_start;
    const int y = static_cast<int32_t>(fam->bit_y[i]) + border_start;
    if (x < 0 || y < 0 || x >= total || y >= total) continue;
    bits[static_cast<size_t>(y * total + x)] = 1;
  }
  layout->grid = total;
  layout->grid_at_border = at_border;
  layout->reversed_border = fam->reversed_border;
  layout->bits = std::move(bits);
  return true;
}

}  // namespace calibd
