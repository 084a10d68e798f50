#pragma once
/// \file
/// Renders what the camera sees of a Scene: mono8, with the CameraModel's distortion applied
/// exactly (every pixel's ray comes from the undistorted pixel position), anti-aliased board faces,
/// blur, exposure variation and sensor noise.

#include <cstdint>
#include <opencv2/core.hpp>
#include <vector>

#include "calibd/core/camera_model.hpp"
#include "scene.hpp"
#include "tag_texture.hpp"

namespace calibd::sim {

struct CameraImaging {
  double blur_sigma_px = 0.7;  ///< Gaussian optical blur
  double noise_sigma = 2.0;    ///< additive Gaussian noise, grey levels
  double exposure_min = 0.8;   ///< per-frame exposure gain drawn uniformly in [min, max]
  double exposure_max = 1.2;
  int board_supersample = 4;  ///< sub-samples per axis on board pixels (anti-aliasing)
};

class CameraRenderer {
 public:
  CameraRenderer(const CameraIntrinsics& intrinsics, const CameraImaging& imaging);

  /// Renders the scene seen from T_world_camera (camera frame: x right, y down, z forward) into
  /// `image` (resized to the intrinsics' size, CV_8UC1, reused between calls). `faces[i]` textures
  /// scene.boards[i]. Deterministic for a given seed.
  void Render(const Scene& scene, const std::vector<BoardFace>& faces, const Pose& T_world_camera,
              uint64_t seed, cv::Mat* image) const;

  const CameraModel& model() const { return model_; }

 private:
  CameraModel model_;
  CameraImaging imaging_;
  std::vector<float> ray_lut_;  ///< per pixel, undistorted normalised (x, y)
};

}  // namespace calibd::sim
