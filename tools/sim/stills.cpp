#include "stills.hpp"

#include <algorithm>
#include <cmath>
#include <random>

namespace calibd::sim {

namespace {

// A thin box from a to b (legs, arms, tripod tubes), `r` its half thickness.
Primitive Segment(SurfaceKind kind, const Eigen::Vector3d& a, const Eigen::Vector3d& b, double r,
                  float albedo) {
  const Eigen::Vector3d axis = (b - a).normalized();
  Eigen::Vector3d x = axis.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = axis.cross(Eigen::Vector3d::UnitX());
  x.normalize();
  Primitive p;
  p.shape = Primitive::Shape::kBox;
  p.kind = kind;
  p.T_world_local = Pose::Identity();
  p.T_world_local.linear().col(0) = x;
  p.T_world_local.linear().col(1) = axis.cross(x);
  p.T_world_local.linear().col(2) = axis;
  p.T_world_local.translation() = 0.5 * (a + b);
  p.half_extents = Eigen::Vector3d(r, r, 0.5 * (b - a).norm());
  p.albedo = albedo;
  return p;
}

// Board facing the point `viewer` (z_B towards it, horizontal; y_B up), then turned by yaw about
// the vertical, tipped by tilt about x_B and turned by roll in its plane (board.hpp's frame).
Pose FacingPose(const Eigen::Vector3d& centre, const Eigen::Vector3d& viewer, double yaw,
                double tilt, double roll) {
  Eigen::Vector3d to_viewer = viewer - centre;
  to_viewer.z() = 0.0;
  to_viewer.normalize();
  Eigen::Matrix3d R_facing;
  R_facing.col(2) = to_viewer;
  R_facing.col(1) = Eigen::Vector3d::UnitZ();
  R_facing.col(0) = R_facing.col(1).cross(R_facing.col(2));
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(0.0, 0.0, yaw) * R_facing * RotationFromRpy(tilt, 0.0, roll);
  T.translation() = centre;
  return T;
}

// Floor, four walls around the sensor and furniture along them.
void AddRoom(const Eigen::Vector3d& sensor, std::mt19937_64& rng, Scene* scene) {
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  Primitive ground;
  ground.shape = Primitive::Shape::kPlaneZ0;
  ground.kind = SurfaceKind::kGround;
  ground.albedo = 0.35f;
  scene->Add(ground);
  const double x0 = sensor.x(), y0 = sensor.y();
  scene->Add(Box(SurfaceKind::kWall, {x0 + 11.0, y0, 1.6}, 0.0, {0.1, 7.0, 1.6}, 0.6f));
  scene->Add(Box(SurfaceKind::kWall, {x0 + 2.5, y0 + 7.0, 1.6}, 0.0, {9.0, 0.1, 1.6}, 0.55f));
  scene->Add(Box(SurfaceKind::kWall, {x0 + 2.5, y0 - 7.0, 1.6}, 0.0, {9.0, 0.1, 1.6}, 0.5f));
  scene->Add(Box(SurfaceKind::kWall, {x0 - 6.5, y0, 1.6}, 0.0, {0.1, 7.0, 1.6}, 0.6f));
  // Cabinets and tables along the side walls, a door-like panel: board-sized flat things.
  for (int i = 0; i < 4; ++i) {
    const double side = i % 2 == 0 ? 1.0 : -1.0;
    const double h = 0.4 + 0.5 * u01(rng);
    // Drawn last argument first, the order GCC evaluated them in (they are unsequenced) when
    // the sessions were made.
    const auto reflectivity = static_cast<float>(0.3 + 0.4 * u01(rng));
    const double width = 0.4 + 0.4 * u01(rng);
    const double yaw = 0.1 * (u01(rng) - 0.5);
    scene->Add(Box(SurfaceKind::kClutter, {x0 + 1.0 + 2.5 * i, y0 + side * 6.4, h}, yaw,
                   {width, 0.3, h}, reflectivity));
  }
  scene->Add(Box(SurfaceKind::kClutter, {x0 + 6.0, y0 + 6.8, 1.05}, 0.0, {0.5, 0.02, 1.05}, 0.7f));
}

// A standing person whose body centre is at (x, y) on the floor, facing `heading` (rad).
void AddPerson(const Eigen::Vector3d& at, double heading, Scene* scene) {
  const Eigen::Vector3d side(-std::sin(heading), std::cos(heading), 0.0);
  for (double s : {-1.0, 1.0}) {
    const Eigen::Vector3d foot = at + s * 0.1 * side;
    scene->Add(Cylinder(SurfaceKind::kClutter, foot.x(), foot.y(), 0.07, 0.85, 0.3f));
  }
  scene->Add(Box(SurfaceKind::kClutter, at + Eigen::Vector3d(0.0, 0.0, 1.18), heading,
                 {0.12, 0.2, 0.32}, 0.45f));
  scene->Add(Box(SurfaceKind::kClutter, at + Eigen::Vector3d(0.0, 0.0, 1.62), heading,
                 {0.1, 0.09, 0.12}, 0.5f));
}

// A chair standing on the floor at `at`, turned by `yaw`.
void AddChair(const Eigen::Vector3d& at, double yaw, Scene* scene) {
  const Eigen::Matrix3d R = RotationFromRpy(0.0, 0.0, yaw);
  scene->Add(Box(SurfaceKind::kClutter, at + Eigen::Vector3d(0.0, 0.0, 0.45), yaw,
                 {0.22, 0.22, 0.025}, 0.4f));
  scene->Add(Box(SurfaceKind::kClutter, at + R * Eigen::Vector3d(0.21, 0.0, 0.7), yaw,
                 {0.02, 0.22, 0.22}, 0.4f));
  for (double sx : {-0.19, 0.19})
    for (double sy : {-0.19, 0.19}) {
      const Eigen::Vector3d leg = at + R * Eigen::Vector3d(sx, sy, 0.0);
      scene->Add(Cylinder(SurfaceKind::kClutter, leg.x(), leg.y(), 0.015, 0.43, 0.3f));
    }
}

// A tripod under the board: a bracket from the back of the board's centre to the tilting head, a
// vertical column from there to a hub, three legs to the floor. The bracket reaches back far
// enough that the column stays behind a board tilted towards the viewer (as a real tilting head
// does), at least kColumnClearance behind its back.
void AddTripod(const Pose& T_world_board, const BoardGeometry& g, double thickness, Scene* scene) {
  static constexpr double kColumnClearance = 0.03;
  const Eigen::Vector3d back = T_world_board * Eigen::Vector3d(0.0, 0.0, -thickness);
  const Eigen::Vector3d n = T_world_board.linear().col(2);  // out of the printed face
  Eigen::Vector3d n_flat(n.x(), n.y(), 0.0);
  const double flat = std::max(0.2, n_flat.norm());
  n_flat /= std::max(1e-9, n_flat.norm());
  // The column's distance behind the back face shrinks by -n.z per metre it runs down the board.
  const double reach =
      (kColumnClearance + std::max(0.0, -n.z()) * 0.5 * std::max(g.width_m, g.height_m)) / flat;
  const Eigen::Vector3d head = back - reach * n_flat;
  const Eigen::Vector3d hub(head.x(), head.y(), std::max(0.2, std::min(0.9, 0.7 * head.z())));
  scene->Add(Segment(SurfaceKind::kStand, back, head, 0.015, 0.3f));
  scene->Add(Segment(SurfaceKind::kStand, hub, head, 0.015, 0.3f));
  for (int k = 0; k < 3; ++k) {
    const double a = 2.0 * M_PI * k / 3.0 + 0.4;
    const Eigen::Vector3d foot = hub + Eigen::Vector3d(0.4 * std::cos(a), 0.4 * std::sin(a), 0.0);
    scene->Add(
        Segment(SurfaceKind::kStand, hub, Eigen::Vector3d(foot.x(), foot.y(), 0.0), 0.012, 0.3f));
  }
}

// A person-sized column (0.35 m wide, floor to 2 m) 0.4-0.8 m in front of the board towards the
// sensor, covering `share` of the board's width as the sensor sees it from one side.
void AddOccluder(const Pose& T_world_board, const BoardGeometry& g, const Eigen::Vector3d& sensor,
                 double share, std::mt19937_64& rng, Workshop* out) {
  static constexpr double kWidth = 0.35, kHeight = 2.0;
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  const Eigen::Vector3d centre = T_world_board.translation();
  Eigen::Vector3d away = centre - sensor;
  away.z() = 0.0;
  const double range = away.norm();
  away /= range;
  const Eigen::Vector3d across(-away.y(), away.x(), 0.0);
  // The board's half width across the line of sight, and the column's lateral scale there.
  const double half = 0.5 * g.width_m * std::fabs(T_world_board.linear().col(0).dot(across));
  const double gap = 0.4 + 0.4 * u01(rng);
  const double k = std::max(0.1, (range - gap) / range);
  const double side = u01(rng) < 0.5 ? 1.0 : -1.0;
  // Its inner edge at (half - 2 share half) across the board, seen from the sensor.
  const double inner = (half - 2.0 * share * half) * k;
  Eigen::Vector3d at = centre - gap * away + side * (inner + 0.5 * kWidth) * across;
  at.z() = 0.5 * kHeight;
  out->scene.Add(Box(SurfaceKind::kClutter, at, std::atan2(across.y(), across.x()),
                     {0.5 * kWidth, 0.12, 0.5 * kHeight}, 0.4f));
}

}  // namespace

bool BuildStillPose(const WorkshopOptions& workshop, const StillPoseOptions& o,
                    const LidarModel& lidar, const Pose& T_world_lidar, const BoardVisible& visible,
                    uint64_t seed, int pose, Workshop* out, std::string* error) {
  *out = Workshop{};
  std::mt19937_64 rng(seed * 0x9e3779b97f4a7c15ULL + static_cast<uint64_t>(pose) * 7919 + 17);
  std::uniform_real_distribution<double> u01(0.0, 1.0);
  auto uniform = [&](double lo, double hi) { return lo + (hi - lo) * u01(rng); };
  const Eigen::Vector3d sensor = T_world_lidar.translation();
  AddRoom(sensor, rng, &out->scene);

  std::vector<Eigen::Vector3d> centres;
  for (int i = 0; i < workshop.num_boards; ++i) {
    const BoardGeometry g = WorkshopBoardGeometry(workshop, i);
    const double size = std::max(g.width_m, g.height_m);
    Pose T_world_board = Pose::Identity();
    bool placed = false;
    for (int attempt = 0; attempt < 500 && !placed; ++attempt) {
      const double d = uniform(o.min_distance_m, o.max_distance_m);
      const double half_angle = std::atan(0.5 * size / d) / kDeg2Rad + 1.0;
      // Inside the LiDAR's field (at most +-35 deg across: the camera's test decides the rest);
      // a board larger than the vertical field is centred in it.
      const double az_lo = std::max(lidar.azimuth_min_deg + half_angle, -35.0);
      const double az_hi = std::min(lidar.azimuth_max_deg - half_angle, 35.0);
      double el_lo = lidar.elevation_min_deg + half_angle,
             el_hi = lidar.elevation_max_deg - half_angle;
      if (el_lo > el_hi) el_lo = el_hi = 0.5 * (lidar.elevation_min_deg + lidar.elevation_max_deg);
      el_hi = std::min(el_hi, 20.0);  // people do not hold boards over their heads
      el_lo = std::max(el_lo, -20.0);
      if (az_lo > az_hi || el_lo > el_hi) continue;
      const double az = uniform(az_lo, az_hi) * kDeg2Rad, el = uniform(el_lo, el_hi) * kDeg2Rad;
      const Eigen::Vector3d dir(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az),
                                std::sin(el));
      const Eigen::Vector3d centre = T_world_lidar * (d * dir);
      // Stands and arms hold boards between knee and head height.
      if (centre.z() < 0.5 * g.height_m + 0.25 || centre.z() > 2.3) continue;
      bool apart = true;
      for (const Eigen::Vector3d& c : centres) apart = apart && (c - centre).norm() > size + 0.3;
      if (!apart) continue;
      T_world_board = FacingPose(centre, sensor, uniform(-o.max_yaw_deg, o.max_yaw_deg) * kDeg2Rad,
                                 uniform(-o.max_tilt_deg, o.max_tilt_deg) * kDeg2Rad,
                                 uniform(-o.max_roll_deg, o.max_roll_deg) * kDeg2Rad);
      placed = !visible || visible(T_world_board, g);
    }
    if (!placed) {
      if (error)
        *error = "still pose " + std::to_string(pose) + ": no place for board " +
                 std::to_string(i) + " in both fields of view at " +
                 std::to_string(o.min_distance_m) + "-" + std::to_string(o.max_distance_m) + " m";
      return false;
    }
    if (!AddBoard(workshop, i, T_world_board, out, error)) return false;
    centres.push_back(T_world_board.translation());

    // Viewer-relative directions on the floor: away from the sensor, and to the side.
    Eigen::Vector3d away = T_world_board.translation() - sensor;
    away.z() = 0.0;
    away.normalize();
    const Eigen::Vector3d across(-away.y(), away.x(), 0.0);
    Eigen::Vector3d foot = T_world_board.translation();
    foot.z() = 0.0;
    const double heading = std::atan2(-away.y(), -away.x());
    const double z = T_world_board.translation().z();
    const bool held = o.clutter && u01(rng) < 0.5 && z > 0.8 && z < 1.9;
    if (o.occluded_share > 0.0) AddOccluder(T_world_board, g, sensor, o.occluded_share, rng, out);
    if (held) {
      // Holding it out to one side: body 0.25 m behind the board, half of it beside the board,
      // one arm to the board's near edge.
      const double s = u01(rng) < 0.5 ? 1.0 : -1.0;
      const double offset = 0.5 * g.width_m + uniform(0.0, 0.2);
      const Eigen::Vector3d body = foot + 0.25 * away + s * offset * across;
      AddPerson(body, heading, &out->scene);
      const Eigen::Vector3d shoulder = body + Eigen::Vector3d(0.0, 0.0, 1.42) - s * 0.2 * across;
      const double edge = T_world_board.linear().col(0).dot(across) > 0.0 ? s : -s;
      const Eigen::Vector3d grip =
          T_world_board *
          Eigen::Vector3d(edge * 0.5 * g.width_m, 0.0, -workshop.board_thickness_m - 0.02);
      out->scene.Add(Segment(SurfaceKind::kClutter, shoulder, grip, 0.04, 0.45f));
    } else {
      AddTripod(T_world_board, g, workshop.board_thickness_m, &out->scene);
    }
    if (!o.clutter) continue;
    if (u01(rng) < 0.5) {
      const double s = u01(rng) < 0.5 ? 1.0 : -1.0;
      AddChair(foot + uniform(0.0, 0.6) * away + s * (0.5 * g.width_m + uniform(0.3, 0.8)) * across,
               uniform(0.0, 2.0 * M_PI), &out->scene);
    }
    if (u01(rng) < 0.4) {
      const Eigen::Vector3d wall = foot + uniform(0.5, 1.0) * away + Eigen::Vector3d(0, 0, 1.4);
      out->scene.Add(
          Box(SurfaceKind::kWall, wall, heading + uniform(-0.25, 0.25), {0.05, 2.0, 1.4}, 0.6f));
    }
    if (u01(rng) < 0.5) {
      const double h = uniform(0.12, 0.25);
      out->scene.Add(Box(
          SurfaceKind::kClutter,
          foot + uniform(0.3, 0.9) * away + uniform(-0.3, 0.3) * across + Eigen::Vector3d(0, 0, h),
          u01(rng), {h, h, h}, static_cast<float>(uniform(0.3, 0.7))));
    }
    if (u01(rng) < 0.3) {
      const double s = u01(rng) < 0.5 ? 1.0 : -1.0;
      AddPerson(foot + s * (0.5 * g.width_m + uniform(0.5, 1.0)) * across, heading, &out->scene);
    }
  }
  out->scene.Finalize();
  return true;
}

}  // namespace calibd::sim
