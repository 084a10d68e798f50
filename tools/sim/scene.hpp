#pragma once
/// \file
/// A workshop scene of simple primitives and a ray caster over it. World frame W: z up, ground z =
/// 0.

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "calibd/core/common/geometry.hpp"

namespace calibd::sim {

enum class SurfaceKind { kGround, kWall, kClutter, kBoard, kStand };

struct Primitive {
  enum class Shape { kPlaneZ0, kBox, kCylinder } shape = Shape::kBox;
  SurfaceKind kind = SurfaceKind::kClutter;
  /// kBox: box frame (centre, axes); kCylinder: base centre, axis = local z. Unused for kPlaneZ0.
  Pose T_world_local = Pose::Identity();
  Eigen::Vector3d half_extents{0.5, 0.5, 0.5};  ///< kBox half sizes along local x, y, z (m)
  double radius = 0.1;                          ///< kCylinder radius (m)
  double height = 1.0;                          ///< kCylinder height along local z (m)
  float albedo = 0.5f;   ///< reflectance 0..1: camera grey level and LiDAR intensity
  int board_index = -1;  ///< index into Scene::boards for kBoard, else -1
  /// kBox boards only, a fault: the printed face (local z = +half_extents.z, AddBoard) bent about
  /// the local y axis, bulging this much at its centre line towards +z (negative: away), flat at
  /// the left and right edges: z = h_z + bow_m (1 - (x / h_x)^2). 0: flat.
  double bow_m = 0.0;
};

/// A board placed in the scene: its pose T_world_board (board frame of
/// calibd/core/common/board.hpp).
struct PlacedBoard {
  Pose T_world_board = Pose::Identity();
  int primitive_index = -1;  ///< the kBox primitive that is the board's slab
};

struct Hit {
  double t = 0.0;          ///< distance along the (unit) ray, m
  int primitive = -1;      ///< index into Scene::primitives
  Eigen::Vector3d normal;  ///< unit surface normal in W, facing the ray origin
};

/// Axis-aligned bounding box of a primitive, for culling.
struct Aabb {
  Eigen::Vector3d lo, hi;
};

class AzimuthSectors;

class Scene {
 public:
  std::vector<Primitive> primitives;
  std::vector<PlacedBoard> boards;

  /// Adds a primitive and returns its index. Call Finalize() after the last one.
  int Add(const Primitive& p);
  /// Precomputes bounding boxes. Must be called before casting.
  void Finalize();

  /// Nearest intersection of the ray origin + t * dir (dir unit length) with t in (t_min, t_max).
  bool Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max,
            Hit* hit) const;
  /// The same, testing only the primitives `sectors` (built on this scene, for an origin on its
  /// segment) lists for the ray's azimuth: the same hit, found faster.
  bool Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min, double t_max,
            const AzimuthSectors& sectors, Hit* hit) const;

  /// Bounding box of primitive i (the ground plane has an infinite one).
  const Aabb& bounds(int i) const { return bounds_[i]; }

 private:
  // Cast over candidates[0, count) (ascending indices), or over every primitive when null.
  bool CastAmong(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                 double t_max, const int* candidates, int count, Hit* hit) const;

  std::vector<Aabb> bounds_;
};

/// Culling for Scene::Cast by the ray's azimuth in W (hand-written: a scene of a few dozen
/// primitives needs no BVH library). For rays from anywhere on a segment of origins (a sensor's
/// path during one sweep), each of kSectors equal azimuth sectors lists, in index order, every
/// primitive whose bounding box a ray of that azimuth can enter: the rest cannot be hit, so the
/// nearest hit among the listed ones is the nearest in the scene.
class AzimuthSectors {
 public:
  static constexpr int kSectors = 360;

  void Build(const Scene& scene, const Eigen::Vector3d& origin_a, const Eigen::Vector3d& origin_b);
  /// The primitives a ray along `dir` (W) may hit: [first, first + count).
  const int* Of(const Eigen::Vector3d& dir, int* count) const;

 private:
  std::vector<int> begin_;  // kSectors + 1 offsets into items_
  std::vector<int> items_;
};

/// The 8 corners of a box or cylinder's local bounding box, in its local frame (corner c takes hi
/// on axis k where bit k of c is set). Not defined for the ground plane.
std::array<Eigen::Vector3d, 8> LocalBoxCorners(const Primitive& p);

/// Ray-primitive intersections, exposed for tests. Return the entry distance t in (t_min, t_max)
/// and the outward normal in W; false when there is none.
bool IntersectBox(const Primitive& box, const Eigen::Vector3d& origin, const Eigen::Vector3d& dir,
                  double t_min, double t_max, double* t, Eigen::Vector3d* normal);
bool IntersectCylinder(const Primitive& cyl, const Eigen::Vector3d& origin,
                       const Eigen::Vector3d& dir, double t_min, double t_max, double* t,
                       Eigen::Vector3d* normal);
/// Where the ray o + t d (box frame), entering `box`'s flat +z face at t_flat, meets its bowed
/// one (Primitive::bow_m); t_flat for a flat box or a ray that grazes the face. The bowed
/// surface's normal differs from the flat one's by at most atan(2 bow / h_x): ignored.
double BowedFrontFaceT(const Primitive& box, const Eigen::Vector3d& o_local,
                       const Eigen::Vector3d& d_local, double t_flat);
bool IntersectGround(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                     double t_max, double* t, Eigen::Vector3d* normal);

}  // namespace calibd::sim
