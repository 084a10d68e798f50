#pragma once
/// \file
/// Renders what the camera sees of a Scene: mono8, with the CameraModel's distortion applied
/// exactly (every pixel's ray comes from the undistorted pixel position), anti-aliased board faces,
/// blur, exposure variation and sensor noise.

#include <cstdint>
#include <functional>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "scene.hpp"
#include "tag_texture.hpp"

namespace calibd::sim {

struct CameraImaging {
  double blur_sigma_px = 0.7;  ///< Gaussian optical blur; 0 disables it
  double noise_sigma = 2.0;    ///< additive Gaussian noise, grey levels
  double exposure_min = 0.8;   ///< per-frame exposure gain drawn uniformly in [min, max]
  double exposure_max = 1.2;
  /// Sub-samples per axis on pixels covering a board (anti-aliasing). Tag corners are sub-pixel
  /// accurate only with supersampling; cost grows with its square on board pixels.
  int board_supersample = 4;
  /// Worker threads for ray casting and noise. The image does not depend on it.
  int num_threads = 2;
};

class CameraRenderer {
 public:
  /// Builds the per-pixel ray table (about 60 MB at 3840x1920; shared by the renderers of one
  /// process with the same intrinsics) and the render workspace.
  CameraRenderer(const CameraIntrinsics& intrinsics, const CameraImaging& imaging);
  ~CameraRenderer();
  CameraRenderer(CameraRenderer&&) noexcept;
  CameraRenderer& operator=(CameraRenderer&&) noexcept;

  /// Renders the scene seen from T_world_camera (camera frame: x right, y down, z forward) into
  /// `image` (resized to the intrinsics' size, CV_8UC1, reused between calls). `faces[i]` textures
  /// scene.boards[i]. Deterministic for a given seed. Uses an internal workspace: do not call
  /// concurrently on one renderer. Seen from the same pose as the last Render, only the screen
  /// tiles where a primitive, a board's pose or its face changed are traced again (a still
  /// pose's carried boards, the next pose's boards and clutter); the others keep their radiance,
  /// so the image is the one a whole trace gives, bit for bit.
  void Render(const Scene& scene, const std::vector<BoardFace>& faces, const Pose& T_world_camera,
              uint64_t seed, cv::Mat* image) const;
  /// The same through a rolling shutter: the rows are read out top to bottom, row v seen from
  /// T_world_camera_at(v / height) (0: the first row's time; 1: the end of the readout). Traced in
  /// `bands` bands of rows, each from the pose at its middle row.
  void Render(const Scene& scene, const std::vector<BoardFace>& faces,
              const std::function<Pose(double)>& T_world_camera_at, int bands, uint64_t seed,
              cv::Mat* image) const;
  /// The last Render's scene from the same view again (a still pose's next frame): the
  /// exposure and the sensor noise are drawn anew from `seed`, the rays are not traced again.
  /// The image equals a Render's but for rounding of the radiance kept between the calls (float).
  /// False (nothing rendered) before any Render.
  bool RenderRepeat(uint64_t seed, cv::Mat* image) const;

  const CameraModel& model() const { return model_; }

  /// Undistorted normalised (x, y) of pixel (u, v) from the ray table; NaN where the pixel lies
  /// beyond the model's valid radius.
  Eigen::Vector2d RayAt(int u, int v) const;

 private:
  /// Normalised-coordinate bounds of the rays of one screen tile (its pixels +- 1 px).
  struct TileBounds {
    float x_lo, x_hi, y_lo, y_hi;
  };

  /// What depends on the intrinsics only: built once per intrinsics and process.
  struct RayTable {
    std::vector<float> ray_lut;  ///< per pixel, undistorted normalised (x, y)
    int tiles_x = 0, tiles_y = 0;
    std::vector<TileBounds> tile_bounds;
  };
  /// The scene and view of the last whole-frame Render (camera_render.cpp).
  struct LastView;

  static std::shared_ptr<const RayTable> SharedRayTable(const CameraModel& model, int num_threads);

  CameraModel model_;
  CameraImaging imaging_;
  std::shared_ptr<const RayTable> rays_;
  mutable cv::Mat shaded_;      ///< workspace: the noiseless, unblurred frame
  mutable cv::Mat radiance_;    ///< the last Render's linear radiance per pixel (CV_32FC1)
  mutable cv::Mat radiance64_;  ///< the same as traced (CV_64FC1): tiles kept by a later Render
  mutable bool has_radiance_ = false;
  mutable std::unique_ptr<LastView> last_view_;
  /// Exposure and noise seed of a frame, drawn from its seed in that order.
  void DrawFrame(uint64_t seed, double* exposure, uint64_t* noise_seed) const;
  /// Rows [v_begin, v_end) of shaded_ and radiance_, seen from T_world_camera at `exposure`.
  /// With `whole_frame` (rows 0..height, one pose), only the tiles that changed since the last
  /// whole-frame trace from the same pose are traced, and this view is kept for the next.
  void TraceRows(const Scene& scene, const std::vector<BoardFace>& faces,
                 const Pose& T_world_camera, int v_begin, int v_end, double exposure,
                 bool whole_frame) const;
  /// shaded_ at `exposure` into `image`: the lens blur, then the sensor noise.
  void Finish(uint64_t noise_seed, cv::Mat* image) const;
};

}  // namespace calibd::sim
