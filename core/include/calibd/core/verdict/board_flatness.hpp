#pragma once
/// \file
/// How far each board's face bends out of its plane, from the LiDAR's points on it (a warped
/// board). The paper's box cost (Eq. 3) takes every board as flat; a board bent by
/// a centimetre puts its LiDAR points up to a centimetre off the plane its tag's corners define,
/// and the solution takes the difference up as a shift and a turn.
///
/// Per observation the points, in the board frame of the camera's (refined) board pose at the
/// solved extrinsic, are fitted with z = a + b_u u + b_v v + c_u (1 - u^2) + c_v (1 - v^2)
/// (u = 2x / width, v = 2y / height): a plane (which absorbs the pose's errors) and the two
/// cylindrical bends, about the board's vertical (c_u) and horizontal (c_v) centre lines, each
/// the height of the bend at that line over the edges. A board's bend is the weighted mean over
/// its observations; its sigma the larger of the least-squares one and one from the observations'
/// scatter over blocks of consecutive frames (errors shared by the frames of one pose).

#include <limits>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/session/board_observation.hpp"

namespace calibd {

struct BoardBend {
  int board_index = -1;
  int observations = 0;  ///< observations that entered the fit
  /// Height of the face at its vertical (u) and horizontal (v) centre lines over its edges, m,
  /// towards the printed side's viewer positive; sigma infinite when not measured.
  double bend_u_m = 0.0, bend_v_m = 0.0;
  double sigma_u_m = std::numeric_limits<double>::infinity();
  double sigma_v_m = std::numeric_limits<double>::infinity();
};

/// One entry per configured board seen in `set` (board_index ascending). `T_camera_board` holds
/// one pose per observation of `set` (e.g. DirectResult::T_camera_board); empty: the camera's.
std::vector<BoardBend> EstimateBoardBends(const std::vector<BoardGeometry>& boards,
                                          const ObservationSet& set, const Pose& T_camera_lidar,
                                          const std::vector<Pose>& T_camera_board);

}  // namespace calibd
