#include "calibd/agent/capture_guidance.hpp"

#include <bitset>

#include "append_int.hpp"
#include "calibd/agent/agent_config.hpp"

namespace calibd {

namespace {

constexpr const char* kDistanceBinNames[kDistanceBins] = {"0-8.5 m", "8.5-15 m", "15-25 m",
                                                          "25+ m"};
// Quadrant q = (lower half) * 2 + (right half); row 0 is the top of the image.
constexpr const char* kQuadrantNames[4] = {"top-left", "top-right", "bottom-left", "bottom-right"};

int CountBits(uint32_t bits) { return static_cast<int>(std::bitset<32>(bits).count()); }

// " (3 of 4 distance bins, 3 needed)"
void AppendCount(std::string* s, int have, int of, const char* what, int needed) {
  *s += " (";
  AppendInt(s, have);
  *s += " of ";
  AppendInt(s, of);
  *s += ' ';
  *s += what;
  *s += ", ";
  AppendInt(s, needed);
  *s += " needed)";
}

uint32_t CoveredQuadrants(uint32_t cells) {
  uint32_t quadrants = 0;
  for (int cell = 0; cell < kImageCells; ++cell) {
    if (!(cells & (1u << cell))) continue;
    const int row = cell / kImageGridSide, col = cell % kImageGridSide;
    quadrants |= 1u << ((2 * row >= kImageGridSide ? 2 : 0) + (2 * col >= kImageGridSide ? 1 : 0));
  }
  return quadrants;
}

}  // namespace

int DistanceBinsSeen(const CaptureCoverage& c) {
  return CountBits(c.distance_bins & ((1u << kDistanceBins) - 1));
}

int ImageCellsSeen(const CaptureCoverage& c) {
  return CountBits(c.image_cells & ((1u << kImageCells) - 1));
}

const char* DistanceBinName(int bin) {
  return bin >= 0 && bin < kDistanceBins ? kDistanceBinNames[bin] : "?";
}

const char* ImageQuadrantName(int quadrant) {
  return quadrant >= 0 && quadrant < 4 ? kQuadrantNames[quadrant] : "?";
}

void AppendCaptureGuidance(const CaptureCoverage& c, std::string* out) {
  if (c.frames_with_boards == 0) {
    *out += c.moving ? "no board seen yet: drive towards the boards"
                     : "no board seen yet: place the boards in view of both sensors";
    return;
  }
  const size_t start = out->size();
  const int bins = DistanceBinsSeen(c);
  if (bins < c.gates.min_distance_bins) {
    *out += c.moving ? "drive so that boards are seen at " : "move boards to ";
    const char* separator = "";
    for (int b = 0; b < kDistanceBins; ++b) {
      if (c.distance_bins & (1u << b)) continue;
      *out += separator;
      *out += kDistanceBinNames[b];
      separator = ", ";
    }
    AppendCount(out, bins, kDistanceBins, "distance bins", c.gates.min_distance_bins);
  }
  const int cells = ImageCellsSeen(c);
  if (cells < c.gates.min_image_cells) {
    if (out->size() > start) *out += "; ";
    const uint32_t quadrants = CoveredQuadrants(c.image_cells);
    if (quadrants == 0xfu) {
      *out += "spread the boards across the image";
    } else {
      *out += "boards needed in the image's ";
      const char* separator = "";
      for (int q = 0; q < 4; ++q) {
        if (quadrants & (1u << q)) continue;
        *out += separator;
        *out += kQuadrantNames[q];
        separator = ", ";
      }
    }
    AppendCount(out, cells, kImageCells, "image cells", c.gates.min_image_cells);
  }
  if (out->size() > start) return;
  if (c.frames_with_boards < c.gates.min_frames) {
    *out += "coverage complete: keep collecting (";
    AppendInt(out, c.frames_with_boards);
    *out += " of ";
    AppendInt(out, c.gates.min_frames);
    *out += " frame pairs)";
  } else if (c.boards < c.gates.min_boards) {
    *out += "coverage complete: keep collecting (";
    AppendInt(out, c.boards);
    *out += " of ";
    AppendInt(out, c.gates.min_boards);
    *out += " boards)";
  } else {
    *out += "coverage complete: collecting up to ";
    AppendInt(out, c.gates.target_frames);
    *out += " frame pairs";
  }
}

}  // namespace calibd
