#include "scene.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "workshop.hpp"

namespace calibd::sim {
namespace {

Primitive UnitBoxAt(const Pose& T_world_local, Eigen::Vector3d half = {0.5, 0.5, 0.5}) {
  Primitive p;
  p.shape = Primitive::Shape::kBox;
  p.T_world_local = T_world_local;
  p.half_extents = half;
  return p;
}

TEST(SceneTest, RayHitsAxisAlignedBoxFrontFace) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  const Primitive box = UnitBoxAt(T);
  double t = 0.0;
  Eigen::Vector3d n;
  ASSERT_TRUE(
      IntersectBox(box, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0, 100.0, &t, &n));
  EXPECT_NEAR(t, 4.5, 1e-12);
  EXPECT_NEAR(n.x(), -1.0, 1e-12);
}

TEST(SceneTest, RayMissesBoxBesideIt) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(5.0, 0.6, 0.0);
  double t = 0.0;
  Eigen::Vector3d n;
  EXPECT_FALSE(IntersectBox(UnitBoxAt(T), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0,
                            100.0, &t, &n));
}

TEST(SceneTest, RotatedBoxHitDistanceMatchesGeometry) {
  // A thin slab rotated 45 deg about z, centred at (4, 0, 0): the ray along x meets its face where
  // the face plane crosses the x axis, at 4 - h*sqrt(2) for half thickness h.
  Pose T = Pose::Identity();
  T.linear() = RotationFromRpy(0.0, 0.0, M_PI / 4.0);
  T.translation() = Eigen::Vector3d(4.0, 0.0, 0.0);
  const double h = 0.01;
  double t = 0.0;
  Eigen::Vector3d n;
  ASSERT_TRUE(IntersectBox(UnitBoxAt(T, {h, 1.0, 1.0}), Eigen::Vector3d::Zero(),
                           Eigen::Vector3d::UnitX(), 0.0, 100.0, &t, &n));
  EXPECT_NEAR(t, 4.0 - h * std::sqrt(2.0), 1e-12);
  EXPECT_NEAR(n.dot(Eigen::Vector3d(-1, -1, 0).normalized()), 1.0, 1e-12);
}

TEST(SceneTest, ABowedBoardIsMetOnItsBentFace) {
  // A 0.9 x 0.9 m slab 5 m along x, its printed face (local +z) towards the origin, its local x
  // along world y; bent 20 mm towards the rays at its centre line, flat at its left and right.
  Pose T = Pose::Identity();
  T.linear() << 0, 0, -1, 1, 0, 0, 0, -1, 0;  // local x -> world y, y -> -z, z -> -x
  T.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  Primitive board = UnitBoxAt(T, {0.45, 0.45, 0.005});
  board.bow_m = 0.02;
  for (const double y : {0.0, 0.2, -0.3, 0.449}) {
    double t = 0.0;
    Eigen::Vector3d n;
    ASSERT_TRUE(IntersectBox(board, Eigen::Vector3d(0.0, y, 0.1), Eigen::Vector3d::UnitX(), 0.0,
                             100.0, &t, &n));
    const double u = y / 0.45;
    EXPECT_NEAR(t, 4.995 - 0.02 * (1.0 - u * u), 1e-9) << "y " << y;
  }
  // Slanted rays converge on the bent surface too: the hit lies on it.
  const Eigen::Vector3d o(0.0, -1.0, 0.3), d = Eigen::Vector3d(5.0, 1.2, -0.3).normalized();
  double t = 0.0;
  Eigen::Vector3d n;
  ASSERT_TRUE(IntersectBox(board, o, d, 0.0, 100.0, &t, &n));
  const Eigen::Vector3d p = o + t * d;
  const double u = p.y() / 0.45;
  EXPECT_NEAR(p.x(), 4.995 - 0.02 * (1.0 - u * u), 1e-9);
  board.bow_m = -0.02;  // bent away: met behind the flat face
  ASSERT_TRUE(
      IntersectBox(board, Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0, 100.0, &t, &n));
  EXPECT_NEAR(t, 5.015, 1e-9);
}

TEST(SceneTest, BoxRespectsTMax) {
  Pose T = Pose::Identity();
  T.translation() = Eigen::Vector3d(5.0, 0.0, 0.0);
  double t = 0.0;
  Eigen::Vector3d n;
  EXPECT_FALSE(IntersectBox(UnitBoxAt(T), Eigen::Vector3d::Zero(), Eigen::Vector3d::UnitX(), 0.0,
                            4.0, &t, &n));
}

TEST(SceneTest, CylinderSideAndCap) {
  Primitive c;
  c.shape = Primitive::Shape::kCylinder;
  c.T_world_local.translation() = Eigen::Vector3d(3.0, 0.0, 0.0);
  c.radius = 0.2;
  c.height = 2.0;
  double t = 0.0;
  Eigen::Vector3d n;
  ASSERT_TRUE(
      IntersectCylinder(c, Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 0.0, 100.0, &t, &n));
  EXPECT_NEAR(t, 2.8, 1e-12);
  EXPECT_NEAR(n.x(), -1.0, 1e-12);
  // From above, straight down onto the top cap.
  ASSERT_TRUE(IntersectCylinder(c, Eigen::Vector3d(3.05, 0, 5), -Eigen::Vector3d::UnitZ(), 0.0,
                                100.0, &t, &n));
  EXPECT_NEAR(t, 3.0, 1e-12);
  EXPECT_NEAR(n.z(), 1.0, 1e-12);
  // Passing above the top misses.
  EXPECT_FALSE(IntersectCylinder(c, Eigen::Vector3d(0, 0, 2.5), Eigen::Vector3d::UnitX(), 0.0,
                                 100.0, &t, &n));
}

TEST(SceneTest, CastReturnsNearestPrimitive) {
  Scene scene;
  Primitive ground;
  ground.shape = Primitive::Shape::kPlaneZ0;
  ground.kind = SurfaceKind::kGround;
  scene.Add(ground);
  Pose near = Pose::Identity(), far = Pose::Identity();
  near.translation() = Eigen::Vector3d(5.0, 0.0, 1.0);
  far.translation() = Eigen::Vector3d(9.0, 0.0, 1.0);
  const int far_id = scene.Add(UnitBoxAt(far));
  const int near_id = scene.Add(UnitBoxAt(near));
  scene.Finalize();
  Hit hit;
  ASSERT_TRUE(scene.Cast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d::UnitX(), 0.0, 100.0, &hit));
  EXPECT_EQ(hit.primitive, near_id);
  EXPECT_NEAR(hit.t, 4.5, 1e-12);
  EXPECT_NE(hit.primitive, far_id);
  // Looking down at 45 deg hits the ground first.
  ASSERT_TRUE(scene.Cast(Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(1, 0, -1).normalized(), 0.0,
                         100.0, &hit));
  EXPECT_EQ(scene.primitives[hit.primitive].kind, SurfaceKind::kGround);
  EXPECT_NEAR(hit.t, std::sqrt(2.0), 1e-12);
}

// Culling by azimuth changes no hit: rays in every direction (up and down too, and straight up)
// from origins along a sensor's path through the workshop, beside a crate and standing inside a
// box, hit with the sectors what they hit without them.
TEST(SceneTest, AzimuthSectorsChangeNoHit) {
  Workshop workshop;
  std::string error;
  ASSERT_TRUE(BuildWorkshop(WorkshopOptions{}, 7, &workshop, &error)) << error;
  Scene& scene = workshop.scene;
  Pose inside_pose = Pose::Identity();
  inside_pose.translation() = Eigen::Vector3d(-20.0, 0.0, 1.0);
  scene.Add(UnitBoxAt(inside_pose, {1.0, 1.0, 1.0}));  // a box around one path's origins
  scene.Finalize();
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  const std::pair<Eigen::Vector3d, Eigen::Vector3d> paths[] = {
      {{-10.0, 0.0, 1.8}, {-9.75, 0.02, 1.8}},  // a drive, 0.25 m a sweep
      {{-3.0, 0.0, 1.8}, {-3.0, 0.0, 1.8}},     // standing still
      {{-20.2, 0.1, 1.2}, {-19.8, 0.1, 1.2}},   // inside the added box
  };
  int hits = 0, checked = 0;
  for (const auto& [a, b] : paths) {
    AzimuthSectors sectors;
    sectors.Build(scene, a, b);
    for (int k = 0; k < 20000; ++k) {
      const double s = 0.5 * (u(rng) + 1.0);
      const Eigen::Vector3d origin = a + s * (b - a);
      Eigen::Vector3d dir(u(rng), u(rng), (k % 2 ? 0.3 : 1.0) * u(rng));
      if (k == 0) dir = Eigen::Vector3d::UnitZ();
      dir.normalize();
      Hit all, culled;
      const bool hit_all = scene.Cast(origin, dir, 0.1, 200.0, &all);
      const bool hit_culled = scene.Cast(origin, dir, 0.1, 200.0, sectors, &culled);
      ASSERT_EQ(hit_culled, hit_all) << origin.transpose() << " " << dir.transpose();
      ++checked;
      if (!hit_all) continue;
      ++hits;
      EXPECT_EQ(culled.primitive, all.primitive);
      EXPECT_EQ(culled.t, all.t);
    }
  }
  EXPECT_EQ(checked, 60000);
  EXPECT_GT(hits, checked / 2);  // the rays meet the walls, the floor and the clutter
}

}  // namespace
}  // namespace calibd::sim
