#pragma once
/// \file
/// The workshop: flat ground, walls, clutter (poles, crates, a parked car, people, a door-like
/// panel) and N square calibration boards on stands. World frame W: z up; the boards stand near the
/// line x = 0 facing -x, where the vehicle drives back and forth.

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/core/common/board.hpp"
#include "scene.hpp"
#include "tag_texture.hpp"

namespace calibd::sim {

struct WorkshopOptions {
  int num_boards = 3;
  double board_width_m = 0.6;
  double board_height_m = 0.6;
  double board_thickness_m = 0.01;
  std::string tag_family = "tag36h11";
  double tag_size_m = 0.48;  ///< side of the tag's black square
  std::vector<int> tag_ids;  ///< one per board; empty: 0, 1, 2, ...
  /// One per board: its board, tag and checker square sizes times this, in [0.2, 1] (boards of
  /// several sizes in one workshop); empty: all 1.
  std::vector<double> board_scales;
  /// One per board, a fault: its face bent about its vertical centre line, bulging this much
  /// there towards the sensors (negative: away; Primitive::bow_m), in [-0.1, 0.1] m; empty:
  /// flat boards.
  std::vector<double> board_bows_m;
  /// Index of the board printed with a checkerboard instead of a tag (-1: none; the camera
  /// detector takes one checkerboard beside any number of tags), its inner corners per row and
  /// per column and its square side.
  int checkerboard_board = -1;
  int checker_inner_rows = 5;
  int checker_inner_cols = 7;
  double checker_square_m = 0.07;
  /// Board layout: "spread" (default: boards side by side, varied heights, yaw and tilt), "line"
  /// (side by side, all facing straight at the vehicle: a degenerate case for calibration tests) or
  /// "stack" (boards one above the other).
  std::string layout = "spread";
  double board_spacing_m = 2.2;  ///< lateral distance between neighbouring boards
  bool clutter = true;           ///< poles, crates, car, people, door panel
  bool walls = true;

  bool IsValid(std::string* error) const;
};

struct Workshop {
  Scene scene;
  std::vector<BoardFace> faces;           ///< faces[i] textures scene.boards[i]
  std::vector<BoardGeometry> geometries;  ///< geometries[i] of scene.boards[i]
};

/// The geometry of board i (its id, size, tag or checkerboard) from the options.
BoardGeometry WorkshopBoardGeometry(const WorkshopOptions& options, int i);

/// Adds board i of the options at T_world_board: its slab (a box whose front face is the board
/// frame's z = 0 plane), its face texture and geometry. False with `error` on a bad tag.
bool AddBoard(const WorkshopOptions& options, int i, const Pose& T_world_board, Workshop* out,
              std::string* error);

/// A box primitive centred at `centre`, turned by `yaw` about the vertical, of half sizes `half`.
Primitive Box(SurfaceKind kind, const Eigen::Vector3d& centre, double yaw,
              const Eigen::Vector3d& half, float albedo);
/// An upright cylinder standing on the ground at (x, y).
Primitive Cylinder(SurfaceKind kind, double x, double y, double radius, double height,
                   float albedo);

/// Builds the workshop. Clutter placement depends on `seed`. False with `error` on bad options
/// (unknown tag family, tag id out of range).
bool BuildWorkshop(const WorkshopOptions& options, uint64_t seed, Workshop* out,
                   std::string* error);

}  // namespace calibd::sim
