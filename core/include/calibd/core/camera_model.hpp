#pragma once
/// \file
/// Pinhole camera with radial-tangential (Brown-Conrady, OpenCV's k1,k2,p1,p2,k3) distortion.
/// Pixel convention: OpenCV's, pixel centres at integer coordinates (AprilTag reports +0.5, see
/// docs/conventions.md#apriltag-pixels; convert at the detector boundary). Camera frame: x right, y
/// down, z forward.

#include <Eigen/Core>
#include <string>

namespace calibd {

struct CameraIntrinsics {
  int width = 3840;                 ///< pixels
  int height = 1920;                ///< pixels
  double fx = 3325.0, fy = 3325.0;  ///< focal lengths, pixels (60 deg horizontal FOV at 3840 px)
  double cx = 1919.5, cy = 959.5;   ///< principal point, pixels
  double k1 = -0.08, k2 = 0.03, p1 = 0.0005, p2 = -0.0003, k3 = -0.005;  ///< OpenCV order

  /// True when the values describe a usable camera; otherwise `error` names the bad field.
  bool IsValid(std::string* error) const;
};

/// Projection and back-projection through the distortion model, with the fold-over gate of
/// docs/conventions.md#fold-over: a point whose undistorted radius lies beyond where the radial
/// mapping stops increasing (or far outside the image) is rejected, so points behind or beside the
/// camera never land in the image.
class CameraModel {
 public:
  explicit CameraModel(const CameraIntrinsics& intrinsics);

  const CameraIntrinsics& intrinsics() const { return intrinsics_; }

  /// Distorts normalised coordinates (x/z, y/z) into pixels. No gating.
  Eigen::Vector2d DistortToPixel(const Eigen::Vector2d& xy_normalized) const;

  /// Projects a point in the camera frame to pixels. Returns false when the point is behind the
  /// camera, beyond the valid undistorted radius, or outside the image (with `margin_px`).
  bool Project(const Eigen::Vector3d& p_camera, Eigen::Vector2d* uv, double margin_px = 0.0) const;

  /// Undistorts a pixel into normalised coordinates (x/z, y/z) by Gauss-Newton on the forward
  /// model. Returns false if it did not converge to 1e-9 px (only far outside the valid region).
  bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector2d* xy_normalized) const;

  /// Largest undistorted radius (normalised units) the gate accepts.
  double max_undistorted_radius() const { return max_radius_; }

 private:
  CameraIntrinsics intrinsics_;
  double max_radius_ = 0.0;
};

}  // namespace calibd
