#pragma once
/// \file
/// Where the camera sees a board's outline, against where the configured geometry puts it. The
/// tag gives the board's pose (PnP); the board's edges, a step in brightness between the board's
/// face and what lies behind it, say whether the board is where the config puts it about the
/// tag: a tag printed off the board's centre, or a board of another size than configured. The
/// LiDAR fits the board's outline, so a tag off-centre moves the result by as much; nothing else
/// measures it when every board faces the camera alike (a drive towards boards).

#include <array>
#include <limits>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/image_view.hpp"

namespace calibd {

/// The board's edges in the order of BoardOutline::edge_offset_m: left (-x_B), right (+x_B),
/// bottom (-y_B), top (+y_B).
inline constexpr int kBoardEdges = 4;

struct BoardOutline {
  /// Per edge, how far outward of the configured edge the camera sees the board's edge, m in
  /// the board's plane (negative: inward); NaN where it found none it could trust (too little
  /// contrast, edges hidden or out of the image, samples that disagree).
  std::array<float, kBoardEdges> edge_offset_m = {
      std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN(),
      std::numeric_limits<float>::quiet_NaN(), std::numeric_limits<float>::quiet_NaN()};

  /// The board's centre against the configured one along x_B (right - left) / 2 and y_B
  /// (top - bottom) / 2, m; NaN where either edge is missing.
  double CentreOffsetX() const { return 0.5 * (edge_offset_m[1] - edge_offset_m[0]); }
  double CentreOffsetY() const { return 0.5 * (edge_offset_m[3] - edge_offset_m[2]); }
};

/// Looks for each edge of `board`, at `T_camera_board`, across its configured position: along
/// the edge's outward normal in the board's plane, from just outside the printed pattern to a
/// few centimetres beyond the edge, the first step in brightness (going outward) at least half
/// the strongest one there and of a few grey levels per pixel. Each edge is sampled at points
/// along its middle 70 % (hands and stands at the corners stay out), and its offset is their
/// median, kept only where most samples found an edge and agree with it to about a pixel.
BoardOutline MeasureBoardOutline(const ImageView& image, const CameraModel& camera,
                                 const BoardGeometry& board, const Pose& T_camera_board);

}  // namespace calibd
