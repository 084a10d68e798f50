#include "camera_render.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <atomic>
#include <cmath>
#include <functional>
#include <limits>
#include <mutex>
#include <opencv2/imgproc.hpp>
#include <random>
#include <thread>

#include "opencv_rng.hpp"

namespace calibd::sim {

namespace {

constexpr int kTile = 32;        // screen tile side for primitive culling, pixels
constexpr int kRowChunk = 8;     // rows handed to a worker at a time
constexpr double kTMin = 1e-6;   // ignore hits closer than this to the camera, m
constexpr double kZNear = 1e-3;  // near plane for culling rectangles, m
constexpr double kSkyAlbedo = 0.7;
constexpr double kFrontFaceZ = -1e-4;  // board.hpp: the printed face is z_B = 0
constexpr float kNaN = std::numeric_limits<float>::quiet_NaN();

// Runs body(first_row, last_row) over [0, rows) in chunks on `threads` workers. Each row is
// computed independently of the split, so the output does not depend on the thread count.
template <typename Body>
void ParallelRows(int rows, int threads, const Body& body) {
  std::atomic<int> next{0};
  auto worker = [&]() {
    for (;;) {
      const int r0 = next.fetch_add(kRowChunk);
      if (r0 >= rows) return;
      body(r0, std::min(rows, r0 + kRowChunk));
    }
  };
  std::vector<std::thread> pool;
  for (int i = 1; i < std::max(1, threads); ++i) pool.emplace_back(worker);
  worker();
  for (auto& t : pool) t.join();
}

// floor() without a libm call (the baseline x86-64 target has no SSE4.1 round instruction);
// valid for |v| < 2^62, far beyond any coordinate here.
int64_t FastFloor(double v) {
  const auto i = static_cast<int64_t>(v);
  return i - (v < static_cast<double>(i) ? 1 : 0);
}

// Deterministic integer hash (a 32-bit avalanche mix) for the procedural ground texture.
uint32_t Hash2(int64_t x, int64_t y, uint32_t salt) {
  uint32_t h = static_cast<uint32_t>(x) * 0x8da6b343u ^ static_cast<uint32_t>(y) * 0xd8163841u ^
               salt * 0xcb1ab31fu;
  h ^= h >> 16;
  h *= 0x7feb352du;
  h ^= h >> 15;
  h *= 0x846ca68bu;
  h ^= h >> 16;
  return h;
}

// The four corner values of one noise cell, kept for the next lookup: neighbouring pixels of
// the near floor fall in the same cell, whose hashes then need not be computed again.
struct NoiseCell {
  int64_t ix = std::numeric_limits<int64_t>::min(), iy = 0;
  double v00 = 0.0, v10 = 0.0, v01 = 0.0, v11 = 0.0;
};

// Smooth value noise in [0, 1] over square cells of `cell` metres; `memo` holds the last cell
// looked up with this `cell` and `salt`.
double ValueNoise(double x, double y, double cell, uint32_t salt, NoiseCell* memo) {
  const double gx = x / cell, gy = y / cell;
  const int64_t ix = FastFloor(gx), iy = FastFloor(gy);
  double fx = gx - static_cast<double>(ix), fy = gy - static_cast<double>(iy);
  fx = fx * fx * (3.0 - 2.0 * fx);
  fy = fy * fy * (3.0 - 2.0 * fy);
  if (ix != memo->ix || iy != memo->iy) {
    constexpr double kScale = 1.0 / 4294967296.0;
    memo->ix = ix;
    memo->iy = iy;
    memo->v00 = Hash2(ix, iy, salt) * kScale;
    memo->v10 = Hash2(ix + 1, iy, salt) * kScale;
    memo->v01 = Hash2(ix, iy + 1, salt) * kScale;
    memo->v11 = Hash2(ix + 1, iy + 1, salt) * kScale;
  }
  const NoiseCell& c = *memo;
  return (c.v00 + (c.v10 - c.v00) * fx) * (1.0 - fy) + (c.v01 + (c.v11 - c.v01) * fx) * fy;
}

// Concrete-like floor albedo (about 0.25..0.45) from the world position: blotches of ~0.2 m and
// ~1 m, and faint saw-cut joints every 4 m. Gives the detector a realistic, textured background.
double GroundAlbedo(double x, double y) {
  thread_local NoiseCell fine, coarse;  // each rendering thread's last cells
  const double n =
      0.65 * ValueNoise(x, y, 0.2, 17u, &fine) + 0.35 * ValueNoise(x, y, 1.0, 91u, &coarse);
  double albedo = 0.25 + 0.2 * n;
  const double jx = x * 0.25 - static_cast<double>(FastFloor(x * 0.25 + 0.5));
  const double jy = y * 0.25 - static_cast<double>(FastFloor(y * 0.25 + 0.5));
  if (std::min(std::abs(jx), std::abs(jy)) < 0.012 * 0.25) albedo *= 0.85;
  return albedo;
}

// A primitive as seen from this frame's camera centre, prepared for fast ray tests.
struct FramePrimitive {
  const Primitive* p = nullptr;
  Eigen::Matrix3d R_local_camera;
  Eigen::Vector3d o_local;  // camera centre in the primitive's frame
  Eigen::Vector3d l_local;  // light direction in the primitive's frame
  // Boards only: hit points are shaded in the board frame of board.hpp.
  const BoardFace* face = nullptr;
  Eigen::Matrix3d R_board_camera;
  Eigen::Vector3d o_board;  // camera centre in the board frame
};

struct Rect {
  double x_lo, x_hi, y_lo, y_hi;
};

// Rectangle in normalised image coordinates (x/z, y/z) that contains every ray from the camera
// centre hitting the convex hull of `corners_camera` in front of the near plane; false when the
// hull lies entirely behind it. The hull is clipped at z = kZNear, so a primitive beside the
// camera does not force the whole image.
bool NormalisedRect(const std::array<Eigen::Vector3d, 8>& corners_camera, Rect* rect) {
  std::vector<Eigen::Vector3d> pts;
  pts.reserve(20);
  for (const auto& c : corners_camera) {
    if (c.z() >= kZNear) pts.push_back(c);
  }
  // The 12 box edges join corners whose indices differ in exactly one bit.
  for (int a = 0; a < 8; ++a) {
    for (int bit = 1; bit < 8; bit <<= 1) {
      if (a & bit) continue;
      const Eigen::Vector3d& pa = corners_camera[a];
      const Eigen::Vector3d& pb = corners_camera[a | bit];
      if ((pa.z() < kZNear) == (pb.z() < kZNear)) continue;
      const double s = (kZNear - pa.z()) / (pb.z() - pa.z());
      pts.push_back(pa + s * (pb - pa));
    }
  }
  if (pts.empty()) return false;
  rect->x_lo = rect->y_lo = std::numeric_limits<double>::infinity();
  rect->x_hi = rect->y_hi = -std::numeric_limits<double>::infinity();
  for (const auto& p : pts) {
    const double x = p.x() / p.z(), y = p.y() / p.z();
    rect->x_lo = std::min(rect->x_lo, x);
    rect->x_hi = std::max(rect->x_hi, x);
    rect->y_lo = std::min(rect->y_lo, y);
    rect->y_hi = std::max(rect->y_hi, y);
  }
  return true;
}

bool SameIntrinsics(const CameraIntrinsics& a, const CameraIntrinsics& b) {
  return a.width == b.width && a.height == b.height && a.fx == b.fx && a.fy == b.fy &&
         a.cx == b.cx && a.cy == b.cy && a.model == b.model && a.k1 == b.k1 && a.k2 == b.k2 &&
         a.p1 == b.p1 && a.p2 == b.p2 && a.k3 == b.k3 && a.k4 == b.k4;
}

}  // namespace

std::shared_ptr<const CameraRenderer::RayTable> CameraRenderer::SharedRayTable(
    const CameraModel& model, int num_threads) {
  // The sessions of a campaign share one camera: each used to spend a quarter of a second of
  // Newton iterations on the same table.
  static std::mutex mutex;
  static std::vector<std::pair<CameraIntrinsics, std::weak_ptr<const RayTable>>> cache;
  const CameraIntrinsics& intrinsics = model.intrinsics();
  const std::lock_guard<std::mutex> lock(mutex);
  cache.erase(std::remove_if(cache.begin(), cache.end(),
                             [](const auto& entry) { return entry.second.expired(); }),
              cache.end());
  for (const auto& [key, table] : cache) {
    if (SameIntrinsics(key, intrinsics)) {
      if (auto shared = table.lock()) return shared;
    }
  }
  auto table = std::make_shared<RayTable>();
  const int W = intrinsics.width, H = intrinsics.height;
  std::vector<float>& lut = table->ray_lut;
  lut.assign(static_cast<size_t>(W) * static_cast<size_t>(H) * 2, kNaN);
  ParallelRows(H, num_threads, [&](int v0, int v1) {
    for (int v = v0; v < v1; ++v) {
      Eigen::Vector2d prev;
      bool have_prev = false;
      float* row = lut.data() + static_cast<size_t>(v) * static_cast<size_t>(W) * 2;
      for (int u = 0; u < W; ++u) {
        const Eigen::Vector2d uv(u, v);
        Eigen::Vector2d xy;
        // Warm start from the left neighbour in the same row only, so that rows are independent.
        const bool ok = have_prev ? model.Unproject(uv, prev, &xy) : model.Unproject(uv, &xy);
        have_prev = ok;
        if (!ok) continue;
        prev = xy;
        row[2 * u] = static_cast<float>(xy.x());
        row[2 * u + 1] = static_cast<float>(xy.y());
      }
    }
  });

  // Ray bounds of each tile over its pixels +- 1 px, padded for sub-samples that extrapolate
  // half a pixel beyond the image border.
  table->tiles_x = (W + kTile - 1) / kTile;
  table->tiles_y = (H + kTile - 1) / kTile;
  table->tile_bounds.resize(static_cast<size_t>(table->tiles_x) *
                            static_cast<size_t>(table->tiles_y));
  const auto pad = static_cast<float>(2.0 / std::min(intrinsics.fx, intrinsics.fy));
  for (int ty = 0; ty < table->tiles_y; ++ty) {
    for (int tx = 0; tx < table->tiles_x; ++tx) {
      TileBounds b{std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity(),
                   std::numeric_limits<float>::infinity(), -std::numeric_limits<float>::infinity()};
      for (int v = std::max(0, ty * kTile - 1); v < std::min(H, (ty + 1) * kTile + 1); ++v) {
        for (int u = std::max(0, tx * kTile - 1); u < std::min(W, (tx + 1) * kTile + 1); ++u) {
          const float* r = &lut[(static_cast<size_t>(v) * static_cast<size_t>(W) + u) * 2];
          if (std::isnan(r[0])) continue;
          b.x_lo = std::min(b.x_lo, r[0]);
          b.x_hi = std::max(b.x_hi, r[0]);
          b.y_lo = std::min(b.y_lo, r[1]);
          b.y_hi = std::max(b.y_hi, r[1]);
        }
      }
      b.x_lo -= pad;
      b.x_hi += pad;
      b.y_lo -= pad;
      b.y_hi += pad;
      table->tile_bounds[static_cast<size_t>(ty * table->tiles_x + tx)] = b;
    }
  }
  cache.emplace_back(intrinsics, table);
  return table;
}

CameraRenderer::CameraRenderer(const CameraIntrinsics& intrinsics, const CameraImaging& imaging)
    : model_(intrinsics), imaging_(imaging), rays_(SharedRayTable(model_, imaging.num_threads)) {
  shaded_.create(intrinsics.height, intrinsics.width, CV_8UC1);
  radiance_.create(intrinsics.height, intrinsics.width, CV_32FC1);
  radiance64_.create(intrinsics.height, intrinsics.width, CV_64FC1);
}

CameraRenderer::~CameraRenderer() = default;
CameraRenderer::CameraRenderer(CameraRenderer&&) noexcept = default;
CameraRenderer& CameraRenderer::operator=(CameraRenderer&&) noexcept = default;

namespace {

bool SameFace(const BoardFace& a, const BoardFace& b) {
  const BoardGeometry &g = a.geometry, &h = b.geometry;
  return g.pattern == h.pattern && g.tag_size_m == h.tag_size_m &&
         g.tag_offset_m == h.tag_offset_m && g.checker_inner_rows == h.checker_inner_rows &&
         g.checker_inner_cols == h.checker_inner_cols &&
         g.checker_square_size_m == h.checker_square_size_m && a.grid == b.grid &&
         a.grid_at_border == b.grid_at_border && a.bits == b.bits &&
         a.white_albedo == b.white_albedo && a.black_albedo == b.black_albedo;
}

bool SamePrimitive(const Primitive& a, const Primitive& b) {
  return a.shape == b.shape && a.kind == b.kind &&
         a.T_world_local.matrix() == b.T_world_local.matrix() && a.half_extents == b.half_extents &&
         a.radius == b.radius && a.height == b.height && a.albedo == b.albedo &&
         a.board_index == b.board_index && a.bow_m == b.bow_m;
}

}  // namespace

/// What a whole-frame trace saw, per scene primitive, for the next one from the same pose to
/// find the tiles that changed.
struct CameraRenderer::LastView {
  Pose T_world_camera = Pose::Identity();
  std::vector<Primitive> primitives;
  std::vector<char> has_face;     ///< whether the primitive was shaded as a board's face
  std::vector<Pose> board_poses;  ///< T_world_board of its board (has_face only)
  std::vector<BoardFace> faces;   ///< its face (has_face only)
  std::vector<char> on_screen;    ///< whether the primitive had a screen rectangle
  std::vector<Rect> rects;        ///< its rectangle, with the board margin for boards
};

void CameraRenderer::DrawFrame(uint64_t seed, double* exposure, uint64_t* noise_seed) const {
  // Exposure first, then the noise seed (std::mt19937_64 is fully specified, so the sequence is
  // the same on every platform).
  std::mt19937_64 rng(seed);
  const double u01 = static_cast<double>(rng() >> 11) * 0x1.0p-53;
  *exposure = imaging_.exposure_min + (imaging_.exposure_max - imaging_.exposure_min) * u01;
  *noise_seed = rng();
}

bool CameraRenderer::RenderRepeat(uint64_t seed, cv::Mat* image) const {
  if (!has_radiance_) return false;
  double exposure = 0.0;
  uint64_t noise_seed = 0;
  DrawFrame(seed, &exposure, &noise_seed);
  radiance_.convertTo(shaded_, CV_8UC1, 255.0 * exposure);  // saturating, as Render's
  Finish(noise_seed, image);
  return true;
}

Eigen::Vector2d CameraRenderer::RayAt(int u, int v) const {
  const size_t i =
      (static_cast<size_t>(v) * static_cast<size_t>(model_.intrinsics().width) + u) * 2;
  return {rays_->ray_lut[i], rays_->ray_lut[i + 1]};
}

void CameraRenderer::Render(const Scene& scene, const std::vector<BoardFace>& faces,
                            const Pose& T_world_camera, uint64_t seed, cv::Mat* image) const {
  Render(
      scene, faces, [&](double) { return T_world_camera; }, 1, seed, image);
}

void CameraRenderer::Render(const Scene& scene, const std::vector<BoardFace>& faces,
                            const std::function<Pose(double)>& T_world_camera_at, int bands,
                            uint64_t seed, cv::Mat* image) const {
  double exposure = 0.0;
  uint64_t noise_seed = 0;
  DrawFrame(seed, &exposure, &noise_seed);
  const int H = model_.intrinsics().height;
  bands = std::clamp(bands, 1, H);
  for (int b = 0; b < bands; ++b) {
    const int v0 = H * b / bands, v1 = H * (b + 1) / bands;
    const double middle_row = 0.5 * (v0 + v1);
    TraceRows(scene, faces, T_world_camera_at(middle_row / H), v0, v1, exposure, bands == 1);
  }
  has_radiance_ = true;
  Finish(noise_seed, image);
}

void CameraRenderer::TraceRows(const Scene& scene, const std::vector<BoardFace>& faces,
                               const Pose& T_world_camera, int v_begin, int v_end, double exposure,
                               bool whole_frame) const {
  const CameraIntrinsics& cam = model_.intrinsics();
  const int W = cam.width, H = cam.height;
  const std::vector<float>& ray_lut = rays_->ray_lut;
  const std::vector<TileBounds>& tile_bounds = rays_->tile_bounds;
  const int tiles_x = rays_->tiles_x;
  const Eigen::Matrix3d R_world_camera = T_world_camera.linear();
  const Eigen::Matrix3d R_camera_world = R_world_camera.transpose();
  const Eigen::Vector3d origin = T_world_camera.translation();
  // Fixed key light from above and slightly behind a camera looking along +x in the workshop.
  const Eigen::Vector3d light = Eigen::Vector3d(-0.4, 0.3, 0.85).normalized();

  // Prepare primitives and their screen rectangles (normalised coordinates).
  std::vector<FramePrimitive> prims;
  std::vector<Rect> rects;
  std::vector<int> board_prims;     // indices into prims of board slabs with a face
  std::vector<size_t> scene_index;  // of each of prims
  bool has_ground = false;          // the z = 0 plane is tested by every ray
  const double board_margin = 3.0 / std::min(cam.fx, cam.fy);  // >= 2 px after distortion
  for (size_t i = 0; i < scene.primitives.size(); ++i) {
    const Primitive& p = scene.primitives[i];
    if (p.shape == Primitive::Shape::kPlaneZ0) {
      has_ground = true;
      continue;
    }
    std::array<Eigen::Vector3d, 8> corners = LocalBoxCorners(p);
    for (Eigen::Vector3d& c : corners) c = R_camera_world * (p.T_world_local * c - origin);
    Rect rect;
    if (!NormalisedRect(corners, &rect)) continue;  // entirely behind the camera
    FramePrimitive fp;
    fp.p = &p;
    const Eigen::Matrix3d R_local_world = p.T_world_local.linear().transpose();
    fp.R_local_camera = R_local_world * R_world_camera;
    fp.o_local = R_local_world * (origin - p.T_world_local.translation());
    fp.l_local = R_local_world * light;
    if (p.kind == SurfaceKind::kBoard && p.board_index >= 0 &&
        p.board_index < static_cast<int>(faces.size()) &&
        p.board_index < static_cast<int>(scene.boards.size())) {
      const Pose& T_world_board = scene.boards[static_cast<size_t>(p.board_index)].T_world_board;
      fp.face = &faces[static_cast<size_t>(p.board_index)];
      const Eigen::Matrix3d R_board_world = T_world_board.linear().transpose();
      fp.R_board_camera = R_board_world * R_world_camera;
      fp.o_board = R_board_world * (origin - T_world_board.translation());
      board_prims.push_back(static_cast<int>(prims.size()));
    }
    prims.push_back(fp);
    rects.push_back(rect);
    scene_index.push_back(i);
  }

  // Bin primitives and supersampled board rectangles into tiles (CSR lists, primitive order).
  const size_t num_tiles = tile_bounds.size();
  std::vector<int> tile_prim_begin(num_tiles + 1, 0), tile_prims;
  std::vector<int> tile_board_begin(num_tiles + 1, 0), tile_boards;
  std::vector<Rect> board_rects;
  for (int b : board_prims) {
    Rect r = rects[static_cast<size_t>(b)];
    r.x_lo -= board_margin;
    r.x_hi += board_margin;
    r.y_lo -= board_margin;
    r.y_hi += board_margin;
    board_rects.push_back(r);
  }
  auto overlaps = [](const TileBounds& t, const Rect& r) {
    return r.x_hi >= t.x_lo && r.x_lo <= t.x_hi && r.y_hi >= t.y_lo && r.y_lo <= t.y_hi;
  };
  // Only the tiles of rows [v_begin, v_end) are traced: the others keep empty lists.
  const size_t first_tile = static_cast<size_t>(v_begin / kTile) * static_cast<size_t>(tiles_x);
  const size_t end_tile = std::min(
      num_tiles, static_cast<size_t>((v_end - 1) / kTile + 1) * static_cast<size_t>(tiles_x));
  for (size_t t = 0; t < num_tiles; ++t) {
    if (t < first_tile || t >= end_tile) {
      tile_prim_begin[t + 1] = static_cast<int>(tile_prims.size());
      tile_board_begin[t + 1] = static_cast<int>(tile_boards.size());
      continue;
    }
    const TileBounds& tb = tile_bounds[t];
    for (size_t k = 0; k < prims.size(); ++k) {
      if (overlaps(tb, rects[k])) tile_prims.push_back(static_cast<int>(k));
    }
    tile_prim_begin[t + 1] = static_cast<int>(tile_prims.size());
    for (size_t k = 0; k < board_rects.size(); ++k) {
      if (overlaps(tb, board_rects[k])) tile_boards.push_back(static_cast<int>(k));
    }
    tile_board_begin[t + 1] = static_cast<int>(tile_boards.size());
  }

  // Which tiles to trace: every one, unless the last whole frame was traced from this very pose;
  // then those whose lists held, then or now, a primitive that changed (its pose, size, albedo,
  // or its board's pose or face). The others' rays meet the same primitives, in the same order,
  // as then: their radiance is kept.
  const size_t num_scene = scene.primitives.size();
  LastView now;
  if (whole_frame) {
    now.T_world_camera = T_world_camera;
    now.primitives = scene.primitives;
    now.has_face.assign(num_scene, 0);
    now.board_poses.assign(num_scene, Pose::Identity());
    now.faces.assign(num_scene, BoardFace{});
    now.on_screen.assign(num_scene, 0);
    now.rects.assign(num_scene, Rect{});
    for (size_t k = 0; k < prims.size(); ++k) {
      const size_t i = scene_index[k];
      now.on_screen[i] = 1;
      now.rects[i] = rects[k];
      if (prims[k].face == nullptr) continue;
      now.has_face[i] = 1;
      now.faces[i] = *prims[k].face;
      now.board_poses[i] = scene.boards[static_cast<size_t>(prims[k].p->board_index)].T_world_board;
    }
    for (size_t b = 0; b < board_prims.size(); ++b)
      now.rects[scene_index[static_cast<size_t>(board_prims[b])]] = board_rects[b];
  }
  std::vector<char> trace_tile(num_tiles, 1);
  const LastView* last = last_view_.get();
  if (whole_frame && last != nullptr && last->T_world_camera.matrix() == T_world_camera.matrix()) {
    std::fill(trace_tile.begin(), trace_tile.end(), 0);
    bool all = false;
    auto mark = [&](const LastView& view, size_t i) {
      if (i >= view.primitives.size()) return;
      if (view.primitives[i].shape == Primitive::Shape::kPlaneZ0) all = true;  // every ray's
      if (!view.on_screen[i]) return;
      for (size_t t = 0; t < num_tiles; ++t) {
        if (overlaps(tile_bounds[t], view.rects[i])) trace_tile[t] = 1;
      }
    };
    for (size_t i = 0; i < std::max(num_scene, last->primitives.size()) && !all; ++i) {
      const bool same =
          i < num_scene && i < last->primitives.size() &&
          SamePrimitive(now.primitives[i], last->primitives[i]) &&
          now.has_face[i] == last->has_face[i] &&
          (!now.has_face[i] || (now.board_poses[i].matrix() == last->board_poses[i].matrix() &&
                                SameFace(now.faces[i], last->faces[i])));
      if (same) continue;
      mark(*last, i);
      mark(now, i);
    }
    if (all) std::fill(trace_tile.begin(), trace_tile.end(), 1);
  }

  // Linear radiance (albedo times Lambert-with-ambient shading) along the camera ray through
  // normalised (x, y). The ray direction (x, y, 1) is left unnormalised: every test below is
  // invariant to its length, and t is only compared, never reported.
  auto trace = [&](double x, double y, const int* list, int list_size) -> double {
    if (std::isnan(x)) return 0.0;  // beyond the model's valid radius: no light reaches it
    const Eigen::Vector3d d_camera(x, y, 1.0);
    const Eigen::Vector3d d = R_world_camera * d_camera;
    double best = std::numeric_limits<double>::infinity();
    int hit_prim = -1, hit_axis = -1;
    bool hit_ground = false;
    Eigen::Vector3d hit_normal = Eigen::Vector3d::Zero();  // cylinders only
    if (has_ground && d.z() != 0.0) {
      const double t = -origin.z() / d.z();  // the plane z_W = 0 (scene.hpp)
      if (t > kTMin) {
        best = t;
        hit_ground = true;
      }
    }
    for (int k = 0; k < list_size; ++k) {
      const auto index = static_cast<size_t>(list[k]);
      const Rect& r = rects[index];
      if (x < r.x_lo || x > r.x_hi || y < r.y_lo || y > r.y_hi) continue;  // exact ray cull
      const FramePrimitive& fp = prims[index];
      if (fp.p->shape == Primitive::Shape::kBox) {
        // Slab test in the box frame with the camera centre precomputed there.
        const Eigen::Vector3d d_l = fp.R_local_camera * d_camera;
        const Eigen::Vector3d& o_l = fp.o_local;
        const Eigen::Vector3d& h = fp.p->half_extents;
        double t0 = 0.0, t1 = best;
        int axis = -1;
        bool miss = false;
        for (int a = 0; a < 3 && !miss; ++a) {
          if (d_l[a] == 0.0) {
            miss = o_l[a] < -h[a] || o_l[a] > h[a];
            continue;
          }
          const double inv = 1.0 / d_l[a];
          double ta = (-h[a] - o_l[a]) * inv, tb = (h[a] - o_l[a]) * inv;
          if (ta > tb) std::swap(ta, tb);
          if (ta > t0) {
            t0 = ta;
            axis = a;
          }
          t1 = std::min(t1, tb);
          miss = t0 > t1;
        }
        if (miss || axis < 0) continue;  // no entry face: missed, or the camera is inside
        if (axis == 2 && d_l.z() < 0.0) t0 = BowedFrontFaceT(*fp.p, o_l, d_l, t0);
        best = t0;
        hit_prim = list[k];
        hit_axis = axis;
        hit_ground = false;
      } else {
        double t = 0.0;
        Eigen::Vector3d n;
        if (IntersectCylinder(*fp.p, origin, d, 0.0, best, &t, &n)) {
          best = t;
          hit_prim = list[k];
          hit_axis = -1;
          hit_normal = n.dot(d) > 0.0 ? Eigen::Vector3d(-n) : n;
          hit_ground = false;
        }
      }
    }
    if (hit_ground) {
      const double n_dot_l = origin.z() >= 0.0 ? light.z() : -light.z();
      return GroundAlbedo(origin.x() + best * d.x(), origin.y() + best * d.y()) *
             (0.55 + 0.45 * std::max(0.0, n_dot_l));
    }
    if (hit_prim < 0) return kSkyAlbedo;  // ceiling / open sky
    const FramePrimitive& fp = prims[static_cast<size_t>(hit_prim)];
    double albedo = fp.p->albedo;
    double n_dot_l = 0.0;
    if (hit_axis >= 0) {
      // Entry face: its outward normal points against the ray along the entry axis.
      const double d_axis = fp.R_local_camera.row(hit_axis).dot(d_camera);
      n_dot_l = d_axis > 0.0 ? -fp.l_local[hit_axis] : fp.l_local[hit_axis];
      if (fp.face != nullptr) {
        const Eigen::Vector3d p_board = fp.o_board + best * (fp.R_board_camera * d_camera);
        // The printed face: z_B = 0, or entered through the slab's +z face when it is bowed
        // (Primitive::bow_m), wherever the bend puts it.
        const bool printed =
            p_board.z() > kFrontFaceZ || (fp.p->bow_m != 0.0 && hit_axis == 2 && d_axis < 0.0);
        if (printed) albedo = fp.face->AlbedoAt(p_board.x(), p_board.y());
      }
    } else {
      n_dot_l = hit_normal.dot(light);
    }
    return albedo * (0.55 + 0.45 * std::max(0.0, n_dot_l));
  };

  // Sub-pixel rays by bilinear interpolation of the table (linear extrapolation past the border).
  auto lut_at = [&](double su, double sv, double* x, double* y) {
    const int i0 = std::clamp(static_cast<int>(FastFloor(su)), 0, W - 2);
    const int j0 = std::clamp(static_cast<int>(FastFloor(sv)), 0, H - 2);
    const double fu = su - i0, fv = sv - j0;
    const float* r0 = &ray_lut[(static_cast<size_t>(j0) * static_cast<size_t>(W) + i0) * 2];
    const float* r1 = r0 + static_cast<size_t>(W) * 2;
    for (int c = 0; c < 2; ++c) {
      const double top = r0[c] + (r0[c + 2] - r0[c]) * fu;
      const double bottom = r1[c] + (r1[c + 2] - r1[c]) * fu;
      (c == 0 ? *x : *y) = top + (bottom - top) * fv;
    }
  };

  const int ss = std::max(1, imaging_.board_supersample);
  const double gain = 255.0 * exposure;
  ParallelRows(v_end - v_begin, imaging_.num_threads, [&](int r0, int r1) {
    for (int v = v_begin + r0; v < v_begin + r1; ++v) {
      uint8_t* out = shaded_.ptr<uint8_t>(v);
      float* kept = radiance_.ptr<float>(v);
      const float* lut_row = &ray_lut[static_cast<size_t>(v) * static_cast<size_t>(W) * 2];
      const int ty = v / kTile;
      double* traced = radiance64_.ptr<double>(v);
      for (int u = 0; u < W; ++u) {
        const size_t tile = static_cast<size_t>(ty * tiles_x + u / kTile);
        if (!trace_tile[tile]) {
          out[u] = cv::saturate_cast<uint8_t>(gain * traced[u]);  // kept[u] holds it already
          continue;
        }
        const int* list = tile_prims.data() + tile_prim_begin[tile];
        const int list_size = tile_prim_begin[tile + 1] - tile_prim_begin[tile];
        const double x = lut_row[2 * u], y = lut_row[2 * u + 1];
        bool on_board = false;
        for (int k = tile_board_begin[tile]; k < tile_board_begin[tile + 1] && !on_board; ++k) {
          const Rect& r = board_rects[static_cast<size_t>(tile_boards[static_cast<size_t>(k)])];
          on_board = x >= r.x_lo && x <= r.x_hi && y >= r.y_lo && y <= r.y_hi;
        }
        double value = 0.0;
        if (!on_board || ss == 1) {
          value = trace(x, y, list, list_size);
        } else {
          // Box filter over the pixel's area on an ss x ss grid, averaged in linear albedo
          // (anti-aliasing). The grid's four corner samples go first: when they agree, no single
          // straight edge crosses the grid (the other samples lie in the corners' convex hull),
          // so the pixel is uniform, as inside a tag module, and the other samples are skipped.
          auto sample = [&](int i, int j) {
            double sx = 0.0, sy = 0.0;
            lut_at(u + (i + 0.5) / ss - 0.5, v + (j + 0.5) / ss - 0.5, &sx, &sy);
            return trace(sx, sy, list, list_size);
          };
          const double c00 = sample(0, 0), c10 = sample(ss - 1, 0);
          const double c01 = sample(0, ss - 1), c11 = sample(ss - 1, ss - 1);
          if (c00 == c10 && c00 == c01 && c00 == c11) {
            value = c00;
          } else {
            value = c00 + c10 + c01 + c11;
            for (int j = 0; j < ss; ++j) {
              for (int i = 0; i < ss; ++i) {
                const bool corner = (i == 0 || i == ss - 1) && (j == 0 || j == ss - 1);
                if (!corner) value += sample(i, j);
              }
            }
            value /= ss * ss;
          }
        }
        out[u] = cv::saturate_cast<uint8_t>(gain * value);
        kept[u] = static_cast<float>(value);
        traced[u] = value;
      }
    }
  });
  if (whole_frame)
    last_view_ = std::make_unique<LastView>(std::move(now));
  else
    last_view_.reset();  // a rolling shutter's bands: no one pose
}

void CameraRenderer::Finish(uint64_t noise_seed, cv::Mat* image) const {
  const int W = shaded_.cols, H = shaded_.rows;
  image->create(H, W, CV_8UC1);
  if (imaging_.blur_sigma_px > 0.0) {
    cv::GaussianBlur(shaded_, *image, cv::Size(0, 0), imaging_.blur_sigma_px,
                     imaging_.blur_sigma_px, cv::BORDER_REPLICATE);
  } else {
    shaded_.copyTo(*image);
  }

  // Sensor noise after the optics: one cv::RNG per row, seeded from the frame's noise seed and
  // the row, so the noise does not depend on how rows are split across threads.
  if (imaging_.noise_sigma > 0.0) {
    PrepareOpenCvNormals();
    ParallelRows(H, imaging_.num_threads, [&](int v0, int v1) {
      cv::Mat noise(1, W, CV_32FC1);
      for (int v = v0; v < v1; ++v) {
        cv::RNG row_rng(noise_seed ^ (0x9e3779b97f4a7c15ull * static_cast<uint64_t>(v + 1)));
        row_rng.fill(noise, cv::RNG::NORMAL, 0.0, imaging_.noise_sigma);
        uint8_t* px = image->ptr<uint8_t>(v);
        const float* n = noise.ptr<float>(0);
        for (int u = 0; u < W; ++u) px[u] = cv::saturate_cast<uint8_t>(px[u] + n[u]);
      }
    });
  }
}

}  // namespace calibd::sim
