#include "scene.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include "calibd/core/lidar/range_image.hpp"

namespace calibd::sim {

namespace {
constexpr double kInf = std::numeric_limits<double>::infinity();

Aabb ComputeBounds(const Primitive& p) {
  Aabb b;
  if (p.shape == Primitive::Shape::kPlaneZ0) {
    b.lo = Eigen::Vector3d(-kInf, -kInf, -1e-9);
    b.hi = Eigen::Vector3d(kInf, kInf, 1e-9);
    return b;
  }
  b.lo = Eigen::Vector3d::Constant(kInf);
  b.hi = Eigen::Vector3d::Constant(-kInf);
  for (const Eigen::Vector3d& corner : LocalBoxCorners(p)) {
    const Eigen::Vector3d w = p.T_world_local * corner;
    b.lo = b.lo.cwiseMin(w);
    b.hi = b.hi.cwiseMax(w);
  }
  return b;
}

// Slab test against an axis-aligned box; returns the entry distance.
bool SlabEnter(const Eigen::Vector3d& lo, const Eigen::Vector3d& hi, const Eigen::Vector3d& o,
               const Eigen::Vector3d& inv_d, double t_min, double t_max, double* t_enter,
               int* axis) {
  double t0 = t_min, t1 = t_max;
  int enter_axis = -1;
  for (int k = 0; k < 3; ++k) {
    double ta = (lo[k] - o[k]) * inv_d[k];
    double tb = (hi[k] - o[k]) * inv_d[k];
    if (std::isnan(ta) || std::isnan(tb)) {  // ray parallel and on a slab plane
      if (o[k] < lo[k] || o[k] > hi[k]) return false;
      continue;
    }
    if (ta > tb) std::swap(ta, tb);
    if (ta > t0) {
      t0 = ta;
      enter_axis = k;
    }
    if (tb < t1) t1 = tb;
    if (t0 > t1) return false;
  }
  if (enter_axis < 0) return false;  // origin inside the box: no entry surface
  *t_enter = t0;
  *axis = enter_axis;
  return true;
}
}  // namespace

std::array<Eigen::Vector3d, 8> LocalBoxCorners(const Primitive& p) {
  Eigen::Vector3d lo, hi;
  if (p.shape == Primitive::Shape::kBox) {
    lo = -p.half_extents;
    hi = p.half_extents;
  } else {  // cylinder: base centre at the origin, axis along local z
    lo = Eigen::Vector3d(-p.radius, -p.radius, 0.0);
    hi = Eigen::Vector3d(p.radius, p.radius, p.height);
  }
  std::array<Eigen::Vector3d, 8> corners;
  for (int c = 0; c < 8; ++c) {
    corners[c] = Eigen::Vector3d((c & 1) ? hi.x() : lo.x(), (c & 2) ? hi.y() : lo.y(),
                                 (c & 4) ? hi.z() : lo.z());
  }
  return corners;
}

bool IntersectGround(const Eigen::Vector3d& o, const Eigen::Vector3d& d, double t_min, double t_max,
                     double* t, Eigen::Vector3d* normal) {
  if (std::abs(d.z()) < 1e-12) return false;
  const double tt = -o.z() / d.z();
  if (!(tt > t_min && tt < t_max)) return false;
  *t = tt;
  *normal = Eigen::Vector3d(0.0, 0.0, o.z() >= 0.0 ? 1.0 : -1.0);
  return true;
}

bool IntersectBox(const Primitive& box, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                  double t_min, double t_max, double* t, Eigen::Vector3d* normal) {
  const Eigen::Matrix3d R = box.T_world_local.linear();
  const Eigen::Vector3d o_l = R.transpose() * (o - box.T_world_local.translation());
  const Eigen::Vector3d d_l = R.transpose() * d;
  const Eigen::Vector3d inv_d = d_l.cwiseInverse();
  int axis = -1;
  double tt = 0.0;
  if (!SlabEnter(-box.half_extents, box.half_extents, o_l, inv_d, t_min, t_max, &tt, &axis))
    return false;
  Eigen::Vector3d n_l = Eigen::Vector3d::Zero();
  n_l[axis] = d_l[axis] > 0.0 ? -1.0 : 1.0;
  if (axis == 2 && d_l.z() < 0.0) tt = BowedFrontFaceT(box, o_l, d_l, tt);
  *t = tt;
  *normal = R * n_l;
  return true;
}

double BowedFrontFaceT(const Primitive& box, const Eigen::Vector3d& o_local,
                       const Eigen::Vector3d& d_local, double t_flat) {
  const Eigen::Vector3d& h = box.half_extents;
  if (box.bow_m == 0.0 || -d_local.z() < 1e-3 * d_local.norm()) return t_flat;
  // Fixed-point iteration on the face's height over x; it contracts while the slope 2 bow x /
  // h_x^2 times |d_x / d_z| stays below 1, i.e. for any but grazing rays on a board bent by
  // centimetres.
  double t = t_flat;
  for (int i = 0; i < 6; ++i) {
    const double x = std::clamp((o_local.x() + t * d_local.x()) / h.x(), -1.0, 1.0);
    t = (h.z() + box.bow_m * (1.0 - x * x) - o_local.z()) / d_local.z();
  }
  return t;
}

bool IntersectCylinder(const Primitive& cyl, const Eigen::Vector3d& o, const Eigen::Vector3d& d,
                       double t_min, double t_max, double* t, Eigen::Vector3d* normal) {
  const Eigen::Matrix3d R = cyl.T_world_local.linear();
  const Eigen::Vector3d o_l = R.transpose() * (o - cyl.T_world_local.translation());
  const Eigen::Vector3d d_l = R.transpose() * d;
  double best = t_max;
  Eigen::Vector3d n_best = Eigen::Vector3d::Zero();
  bool found = false;
  // Side: (ox + t dx)^2 + (oy + t dy)^2 = r^2, with 0 <= z <= height.
  const double a = d_l.x() * d_l.x() + d_l.y() * d_l.y();
  if (a > 1e-15) {
    const double b = 2.0 * (o_l.x() * d_l.x() + o_l.y() * d_l.y());
    const double c = o_l.x() * o_l.x() + o_l.y() * o_l.y() - cyl.radius * cyl.radius;
    const double disc = b * b - 4.0 * a * c;
    if (disc >= 0.0) {
      const double sq = std::sqrt(disc);
      const double t0 = (-b - sq) / (2.0 * a);  // entry only: rays never start inside a pole
      const double z = o_l.z() + t0 * d_l.z();
      if (t0 > t_min && t0 < best && z >= 0.0 && z <= cyl.height) {
        best = t0;
        n_best = Eigen::Vector3d(o_l.x() + t0 * d_l.x(), o_l.y() + t0 * d_l.y(), 0.0).normalized();
        found = true;
      }
    }
  }
  // Caps at z = 0 and z = height.
  if (std::abs(d_l.z()) > 1e-15) {
    for (double zc : {0.0, cyl.height}) {
      const double tc = (zc - o_l.z()) / d_l.z();
      if (!(tc > t_min && tc < best)) continue;
      const double x = o_l.x() + tc * d_l.x(), y = o_l.y() + tc * d_l.y();
      if (x * x + y * y > cyl.radius * cyl.radius) continue;
      best = tc;
      n_best = Eigen::Vector3d(0.0, 0.0, d_l.z() > 0.0 ? -1.0 : 1.0);
      found = true;
    }
  }
  if (!found) return false;
  *t = best;
  *normal = R * n_best;
  return true;
}

int Scene::Add(const Primitive& p) {
  primitives.push_back(p);
  return static_cast<int>(primitives.size()) - 1;
}

void Scene::Finalize() {
  bounds_.clear();
  bounds_.reserve(primitives.size());
  for (const auto& p : primitives) bounds_.push_back(ComputeBounds(p));
}

bool Scene::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                 double t_max, Hit* hit) const {
  return CastAmong(origin, dir, t_min, t_max, nullptr, static_cast<int>(primitives.size()), hit);
}

bool Scene::Cast(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                 double t_max, const AzimuthSectors& sectors, Hit* hit) const {
  int count = 0;
  const int* candidates = sectors.Of(dir, &count);
  return CastAmong(origin, dir, t_min, t_max, candidates, count, hit);
}

bool Scene::CastAmong(const Eigen::Vector3d& origin, const Eigen::Vector3d& dir, double t_min,
                      double t_max, const int* candidates, int count, Hit* hit) const {
  const Eigen::Vector3d inv_d = dir.cwiseInverse();
  double best = t_max;
  bool found = false;
  for (int k = 0; k < count; ++k) {
    const auto i = static_cast<size_t>(candidates ? candidates[k] : k);
    const Primitive& p = primitives[i];
    double t = 0.0;
    Eigen::Vector3d n;
    bool ok = false;
    switch (p.shape) {
      case Primitive::Shape::kPlaneZ0:
        ok = IntersectGround(origin, dir, t_min, best, &t, &n);
        break;
      case Primitive::Shape::kBox:
      case Primitive::Shape::kCylinder: {
        double te = 0.0;
        int axis = 0;
        // Cheap world-AABB rejection first (also rejects boxes farther than the best hit).
        const Aabb& b = bounds_[i];
        const bool inside =
            (origin.array() >= b.lo.array()).all() && (origin.array() <= b.hi.array()).all();
        if (!inside && !SlabEnter(b.lo, b.hi, origin, inv_d, t_min, best, &te, &axis)) break;
        ok = p.shape == Primitive::Shape::kBox
                 ? IntersectBox(p, origin, dir, t_min, best, &t, &n)
                 : IntersectCylinder(p, origin, dir, t_min, best, &t, &n);
        break;
      }
    }
    if (ok && t < best) {
      best = t;
      hit->t = t;
      hit->primitive = static_cast<int>(i);
      hit->normal = n.dot(dir) > 0.0 ? Eigen::Vector3d(-n) : n;
      found = true;
    }
  }
  return found;
}

namespace {

constexpr double kSectorWidth = 2.0 * M_PI / AzimuthSectors::kSectors;

int SectorOf(double azimuth) {
  const auto s = static_cast<int>(std::floor((azimuth + M_PI) / kSectorWidth));
  return ((s % AzimuthSectors::kSectors) + AzimuthSectors::kSectors) % AzimuthSectors::kSectors;
}

}  // namespace

void AzimuthSectors::Build(const Scene& scene, const Eigen::Vector3d& origin_a,
                           const Eigen::Vector3d& origin_b) {
  const Eigen::Vector2d mid = 0.5 * (origin_a + origin_b).head<2>();
  const double half = 0.5 * (origin_b - origin_a).head<2>().norm();
  // Per sector, which primitives a ray of its azimuth may enter the bounds of.
  std::vector<std::vector<char>> listed(static_cast<size_t>(kSectors),
                                        std::vector<char>(scene.primitives.size(), 0));
  for (size_t i = 0; i < scene.primitives.size(); ++i) {
    bool all = scene.primitives[i].shape == Primitive::Shape::kPlaneZ0;
    double lo = 0.0, hi = 0.0, centre = 0.0;
    if (!all) {
      const Aabb& b = scene.bounds(static_cast<int>(i));
      // Horizontal distance from the segment's middle to the box's footprint: an origin within
      // `half` of it that could stand inside (or on) the footprint sees it in every direction.
      const double dx = std::max({b.lo.x() - mid.x(), 0.0, mid.x() - b.hi.x()});
      const double dy = std::max({b.lo.y() - mid.y(), 0.0, mid.y() - b.hi.y()});
      const double d = std::hypot(dx, dy);
      all = d <= half + 1e-3;
      if (!all) {
        // The footprint's corners bound its azimuths from outside it (a convex polygon); an
        // origin `half` away turns each by at most asin(half / d); a sector of slack each side
        // for rounding.
        centre = std::atan2(0.5 * (b.lo.y() + b.hi.y()) - mid.y(),
                            0.5 * (b.lo.x() + b.hi.x()) - mid.x());
        lo = hi = 0.0;
        for (int c = 0; c < 4; ++c) {
          const double x = (c & 1) ? b.hi.x() : b.lo.x(), y = (c & 2) ? b.hi.y() : b.lo.y();
          const double a = std::remainder(std::atan2(y - mid.y(), x - mid.x()) - centre, 2 * M_PI);
          lo = std::min(lo, a);
          hi = std::max(hi, a);
        }
        const double margin = std::asin(std::min(1.0, half / d)) + kSectorWidth;
        lo -= margin;
        hi += margin;
        all = hi - lo >= 2.0 * M_PI - 2.0 * kSectorWidth;
      }
    }
    if (all) {
      for (auto& l : listed) l[i] = 1;
      continue;
    }
    const int first = SectorOf(centre + lo);
    const int span = static_cast<int>(std::ceil((hi - lo) / kSectorWidth)) + 1;
    for (int k = 0; k <= span && k < kSectors; ++k)
      listed[static_cast<size_t>((first + k) % kSectors)][i] = 1;
  }
  begin_.assign(static_cast<size_t>(kSectors) + 1, 0);
  items_.clear();
  for (size_t s = 0; s < listed.size(); ++s) {
    for (size_t i = 0; i < listed[s].size(); ++i)
      if (listed[s][i]) items_.push_back(static_cast<int>(i));
    begin_[s + 1] = static_cast<int>(items_.size());
  }
}

const int* AzimuthSectors::Of(const Eigen::Vector3d& dir, int* count) const {
  // FastAtan2's error (about 1e-5 rad) lies well inside the sector of slack Build leaves.
  const auto s = static_cast<size_t>(
      SectorOf(FastAtan2(static_cast<float>(dir.y()), static_cast<float>(dir.x()))));
  *count = begin_[s + 1] - begin_[s];
  return items_.data() + begin_[s];
}

}  // namespace calibd::sim
