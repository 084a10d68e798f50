#include "workshop.hpp"

#include <cmath>
#include <random>
#include <set>

#include "calibd/core/common/validation.hpp"

namespace calibd::sim {

Primitive Box(SurfaceKind kind, const Eigen::Vector3d& centre, double yaw,
              const Eigen::Vector3d& half, float albedo) {
  Primitive p;
  p.shape = Primitive::Shape::kBox;
  p.kind = kind;
  p.T_world_local = Pose::Identity();
  p.T_world_local.linear() = RotationFromRpy(0.0, 0.0, yaw);
  p.T_world_local.translation() = centre;
  p.half_extents = half;
  p.albedo = albedo;
  return p;
}

Primitive Cylinder(SurfaceKind kind, double x, double y, double radius, double height,
                   float albedo) {
  Primitive p;
  p.shape = Primitive::Shape::kCylinder;
  p.kind = kind;
  p.T_world_local = Pose::Identity();
  p.T_world_local.translation() = Eigen::Vector3d(x, y, 0.0);
  p.radius = radius;
  p.height = height;
  p.albedo = albedo;
  return p;
}

namespace {

// Board pose: facing the vehicle (z_B = -x_W), x_B = -y_W (the viewer's right), y_B = z_W, then
// turned by yaw about the vertical and tilted by `tilt` about x_B.
Pose BoardPose(const Eigen::Vector3d& centre, double yaw, double tilt) {
  Eigen::Matrix3d R_facing;
  R_facing.col(0) = -Eigen::Vector3d::UnitY();
  R_facing.col(1) = Eigen::Vector3d::UnitZ();
  R_facing.col(2) = -Eigen::Vector3d::UnitX();
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(0.0, 0.0, yaw) * R_facing * RotationFromRpy(tilt, 0.0, 0.0);
  T.translation() = centre;
  return T;
}

struct BoardPlacement {
  Eigen::Vector3d centre;
  double yaw = 0.0, tilt = 0.0;
};

std::vector<BoardPlacement> Layout(const WorkshopOptions& o) {
  std::vector<BoardPlacement> out;
  const int n = o.num_boards;
  // Varied heights, yaws and tilts give the direct optimisation planes of different orientation,
  // which observability needs (all boards parallel is a degenerate configuration).
  static const double kHeights[] = {1.25, 1.75, 1.45, 1.95, 1.15, 1.6};
  static const double kYawDeg[] = {25.0, -10.0, -28.0, 15.0, -20.0, 5.0};
  static const double kTiltDeg[] = {-8.0, 12.0, 4.0, -12.0, 8.0, -4.0};
  for (int i = 0; i < n; ++i) {
    BoardPlacement p;
    const double lateral = (i - (n - 1) / 2.0) * o.board_spacing_m;
    if (o.layout == "stack") {
      p.centre = Eigen::Vector3d(0.0, 0.0, 0.8 + i * (o.board_height_m + 0.15));
    } else {
      p.centre = Eigen::Vector3d(0.0, -lateral, kHeights[i % 6]);
    }
    if (o.layout == "spread") {
      p.yaw = kYawDeg[i % 6] * kDeg2Rad;
      p.tilt = kTiltDeg[i % 6] * kDeg2Rad;
      p.centre.x() = 0.4 * ((i % 3) - 1);  // stagger in depth as well
    }
    out.push_back(p);
  }
  return out;
}

}  // namespace

bool WorkshopOptions::IsValid(std::string* error) const {
  if (num_boards < 1 || num_boards > 12) return Invalid(error, "--boards must be in 1..12");
  if (!(board_width_m > 0.05 && board_width_m < 5.0 && board_height_m > 0.05 &&
        board_height_m < 5.0))
    return Invalid(error, "--board-size must be in (0.05, 5) m");
  if (!FiniteAbove(tag_size_m, 0.0) || tag_size_m > std::min(board_width_m, board_height_m))
    return Invalid(error, "--tag-size must be positive and fit on the board");
  if (!tag_ids.empty() && static_cast<int>(tag_ids.size()) != num_boards)
    return Invalid(
        error, "--tag-ids must list exactly one id per board (" + std::to_string(num_boards) + ")");
  if (std::set<int>(tag_ids.begin(), tag_ids.end()).size() != tag_ids.size())
    return Invalid(error, "--tag-ids must be distinct");
  if (!board_scales.empty() && static_cast<int>(board_scales.size()) != num_boards)
    return Invalid(error, "--board-scales must list exactly one factor per board (" +
                              std::to_string(num_boards) + ")");
  for (const double s : board_scales)
    if (!(s >= 0.2 && s <= 1.0)) return Invalid(error, "--board-scales must be in [0.2, 1]");
  if (!board_bows_m.empty() && static_cast<int>(board_bows_m.size()) != num_boards)
    return Invalid(error, "--board-bows must list exactly one bow per board (" +
                              std::to_string(num_boards) + ")");
  for (const double b : board_bows_m)
    if (!(std::abs(b) <= 0.1)) return Invalid(error, "--board-bows must be in [-0.1, 0.1] m");
  if (checkerboard_board >= num_boards)
    return Invalid(error, "--checkerboard: board index " + std::to_string(checkerboard_board) +
                              " but there are " + std::to_string(num_boards) + " boards");
  if (layout != "spread" && layout != "line" && layout != "stack")
    return Invalid(error, "--layout must be spread, line or stack (got '" + layout + "')");
  if (!(board_spacing_m >= std::max(board_width_m, board_height_m) + 0.1))
    return Invalid(error, "--board-spacing must leave a gap of at least 0.1 m between boards");
  return true;
}

BoardGeometry WorkshopBoardGeometry(const WorkshopOptions& o, int i) {
  BoardGeometry g;
  g.board_id = o.tag_ids.empty() ? i : o.tag_ids[i];
  g.tag_id = g.board_id;
  const double scale = o.board_scales.empty() ? 1.0 : o.board_scales[static_cast<size_t>(i)];
  g.width_m = o.board_width_m * scale;
  g.height_m = o.board_height_m * scale;
  g.tag_family = o.tag_family;
  g.tag_size_m = o.tag_size_m * scale;
  if (i == o.checkerboard_board) {
    g.pattern = BoardGeometry::PatternKind::kCheckerboard;
    g.checker_inner_rows = o.checker_inner_rows;
    g.checker_inner_cols = o.checker_inner_cols;
    g.checker_square_size_m = o.checker_square_m * scale;
  }
  return g;
}

bool AddBoard(const WorkshopOptions& o, int i, const Pose& T_world_board, Workshop* out,
              std::string* error) {
  const BoardGeometry g = WorkshopBoardGeometry(o, i);
  BoardFace face;
  if (!face.Build(g, error)) return false;
  // The slab's front face is the board frame's z = 0 plane (board.hpp), so it sits behind it.
  Primitive slab;
  slab.shape = Primitive::Shape::kBox;
  slab.kind = SurfaceKind::kBoard;
  slab.T_world_local = T_world_board;
  slab.T_world_local.translation() +=
      T_world_board.linear() * Eigen::Vector3d(0.0, 0.0, -o.board_thickness_m / 2.0);
  slab.half_extents = Eigen::Vector3d(g.width_m / 2.0, g.height_m / 2.0, o.board_thickness_m / 2.0);
  slab.albedo = face.white_albedo;
  if (!o.board_bows_m.empty()) slab.bow_m = o.board_bows_m[static_cast<size_t>(i)];
  slab.board_index = static_cast<int>(out->scene.boards.size());
  PlacedBoard placed;
  placed.T_world_board = T_world_board;
  placed.primitive_index = out->scene.Add(slab);
  out->scene.boards.push_back(placed);
  out->faces.push_back(face);
  out->geometries.push_back(g);
  return true;
}

bool BuildWorkshop(const WorkshopOptions& o, uint64_t seed, Workshop* out, std::string* error) {
  if (!o.IsValid(error)) return false;
  *out = Workshop{};
  Scene& scene = out->scene;

  Primitive ground;
  ground.shape = Primitive::Shape::kPlaneZ0;
  ground.kind = SurfaceKind::kGround;
  ground.albedo = 0.35f;
  scene.Add(ground);

  if (o.walls) {
    // Back wall behind the boards, side walls, and a wall behind the vehicle's farthest point.
    scene.Add(Box(SurfaceKind::kWall, {7.0, 0.0, 3.0}, 0.0, {0.1, 14.0, 3.0}, 0.6f));
    scene.Add(Box(SurfaceKind::kWall, {-18.0, 14.0, 3.0}, 0.0, {25.0, 0.1, 3.0}, 0.55f));
    scene.Add(Box(SurfaceKind::kWall, {-18.0, -14.0, 3.0}, 0.0, {25.0, 0.1, 3.0}, 0.5f));
    scene.Add(Box(SurfaceKind::kWall, {-43.0, 0.0, 3.0}, 0.0, {0.1, 14.0, 3.0}, 0.6f));
  }

  const auto placements = Layout(o);
  for (int i = 0; i < o.num_boards; ++i) {
    const Pose T_world_board =
        BoardPose(placements[i].centre, placements[i].yaw, placements[i].tilt);
    if (!AddBoard(o, i, T_world_board, out, error)) return false;
    const BoardGeometry& g = out->geometries.back();

    // Stand: a thin post from the ground to the board's lower edge, just behind the board, on a
    // base plate. The post touches the board, so segmentation must separate them by geometry.
    const Eigen::Vector3d behind = T_world_board * Eigen::Vector3d(0.0, -g.height_m / 2.0 + 0.05,
                                                                   -o.board_thickness_m - 0.025);
    scene.Add(Cylinder(SurfaceKind::kStand, behind.x(), behind.y(), 0.02, std::max(0.1, behind.z()),
                       0.3f));
    scene.Add(
        Box(SurfaceKind::kStand, {behind.x(), behind.y(), 0.015}, 0.0, {0.25, 0.25, 0.015}, 0.25f));
  }

  if (o.clutter) {
    std::mt19937_64 rng(seed ^ 0x5eedc177ULL);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    auto side = [&](double lo, double hi) {  // lateral position outside the vehicle's corridor
      const double y = lo + (hi - lo) * u01(rng);
      return u01(rng) < 0.5 ? y : -y;
    };
    // Poles (pillars, lamp posts).
    for (int i = 0; i < 4; ++i)
      scene.Add(Cylinder(SurfaceKind::kClutter, -5.0 - 8.0 * i, side(6.0, 11.0), 0.15, 4.0, 0.5f));
    // Crates, some near the boards and the back wall.
    for (int i = 0; i < 5; ++i) {
      const double s = 0.4 + 0.4 * u01(rng);
      // Drawn last argument first, the order GCC evaluated them in (function arguments are
      // unsequenced) when the sessions were made; a braced list is sequenced left to right.
      const auto reflectivity = static_cast<float>(0.3 + 0.4 * u01(rng));
      const double yaw = u01(rng);
      const double x = -30.0 * u01(rng) + 4.0;
      scene.Add(Box(SurfaceKind::kClutter, {x, side(5.0, 12.0), s}, yaw, {s, s, s}, reflectivity));
    }
    // A parked car-sized box.
    scene.Add(
        Box(SurfaceKind::kClutter, {-12.0, side(6.5, 8.0), 0.75}, 0.05, {2.25, 0.9, 0.75}, 0.4f));
    // People-sized cylinders standing around.
    for (int i = 0; i < 3; ++i) {
      const double y = side(4.5, 9.0);  // before x: GCC's order of the unsequenced arguments
      scene.Add(Cylinder(SurfaceKind::kClutter, -2.0 - 10.0 * u01(rng), y, 0.25, 1.75, 0.45f));
    }
    // A large flat door-like panel near the boards: the hard negative for a board detector.
    scene.Add(
        Box(SurfaceKind::kClutter, {1.5, side(4.5, 5.5), 1.05}, 0.3, {0.02, 0.5, 1.05}, 0.7f));
  }
  scene.Finalize();
  return true;
}

}  // namespace calibd::sim
