#pragma once
/// \file
/// Where the boards' centres lie against where the config puts them about their tags, as the
/// camera sees the boards' edges (BoardOutline), over a session. A tag printed off its board's
/// centre, or configured so (BoardGeometry::tag_offset_m), moves the LiDAR's board against the
/// camera's by that much in the board's plane; where every board faces the camera alike (a drive
/// towards boards) the solve takes it into the translation whole, and neither sensor's fit shows
/// it.

#include <Eigen/Core>
#include <limits>
#include <vector>

#include "calibd/core/session/board_observation.hpp"

namespace calibd {

struct BoardCentreOffset {
  int board_index = -1;  ///< into the configured boards
  /// The board's centre from the configured one, m, along x_B and y_B; sigma infinite where
  /// the camera could not measure that axis (both of its edges in a few stretches of frames).
  Eigen::Vector2d offset_m = Eigen::Vector2d::Zero();
  Eigen::Vector2d sigma_m = Eigen::Vector2d::Constant(std::numeric_limits<double>::infinity());
  int observations = 0;  ///< of this board, with either axis measured
};

struct BoardCentreOffsets {
  std::vector<BoardCentreOffset> boards;  ///< the boards measured, in board order
  /// What the offsets move the result's translation by where the solve takes them whole: the
  /// mean over the observations of each board's offset turned into the camera frame, m, and its
  /// covariance (the boards' sigmas, independent).
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero();
  Eigen::Matrix3d translation_cov = Eigen::Matrix3d::Zero();
  bool measured() const { return !boards.empty(); }
};

/// Each board's centre offset: per axis, the mean over up to 8 stretches of consecutive frames
/// of their observations' mean (right - left) / 2 or (top - bottom) / 2 (BoardOutline), with a
/// sigma from the stretches' scatter at the 99 % of Student's t for their number (at least 3).
BoardCentreOffsets EstimateBoardCentreOffsets(const ObservationSet& set, int num_boards);

}  // namespace calibd
