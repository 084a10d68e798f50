#pragma once
/// \file
/// Pinhole camera with one of two distortion models: radial-tangential (Brown-Conrady, OpenCV's
/// k1,k2,p1,p2,k3) or Kannala-Brandt equidistant fisheye (OpenCV's cv::fisheye k1..k4).
/// Pixel convention: OpenCV's, pixel centres at integer coordinates (AprilTag reports +0.5, see
/// docs/conventions.md#apriltag-pixels; convert at the detector boundary). Camera frame: x right, y
/// down, z forward.

#include <Eigen/Core>
#include <string>

namespace calibd {

/// Which lens distortion model CameraIntrinsics describes.
enum class DistortionModel {
  /// Radial-tangential (OpenCV's default model): uses k1, k2, p1, p2, k3; k4 must be 0.
  kRadTan,
  /// Kannala-Brandt equidistant fisheye (OpenCV's cv::fisheye): theta_d = theta (1 + k1 theta^2 +
  /// k2 theta^4 + k3 theta^6 + k4 theta^8) with theta the angle off the optical axis; uses k1..k4,
  /// p1 and p2 must be 0 (no tangential terms).
  kKannalaBrandt,
};

struct CameraIntrinsics {
  int width = 3840;                 ///< pixels
  int height = 1920;                ///< pixels
  double fx = 3325.0, fy = 3325.0;  ///< focal lengths, pixels (60 deg horizontal FOV at 3840 px)
  double cx = 1919.5, cy = 959.5;   ///< principal point, pixels
  DistortionModel model = DistortionModel::kRadTan;  ///< which coefficients below apply
  /// kRadTan: OpenCV order (k1, k2, p1, p2, k3). kKannalaBrandt: cv::fisheye's D = (k1, k2, k3, k4)
  /// with p1 = p2 = 0.
  double k1 = -0.08, k2 = 0.03, p1 = 0.0005, p2 = -0.0003, k3 = -0.005;
  double k4 = 0.0;  ///< kKannalaBrandt only (must be 0 for kRadTan)

  /// True when the values describe a usable camera; otherwise `error` names the bad field.
  bool IsValid(std::string* error) const;
};

/// Projection and back-projection through the distortion model, with the fold-over gate of
/// docs/conventions.md#fold-over: a point whose undistorted radius lies beyond where the radial
/// mapping stops increasing (or far outside the image) is rejected, so points behind or beside the
/// camera never land in the image. Kannala-Brandt: the gate is at the angle off-axis where
/// theta_d(theta) stops increasing, and below 90 deg (points with z <= 0 are always rejected, so a
/// lens with more than 180 deg field of view is clamped to 180 deg).
class CameraModel {
 public:
  explicit CameraModel(const CameraIntrinsics& intrinsics);

  const CameraIntrinsics& intrinsics() const { return intrinsics_; }

  /// Distorts normalised coordinates (x/z, y/z) into pixels. No gating.
  Eigen::Vector2d DistortToPixel(const Eigen::Vector2d& xy_normalized) const;

  /// Projects a point in the camera frame to pixels. Returns false when the point is behind the
  /// camera, beyond the valid undistorted radius, or outside the image (with `margin_px`).
  bool Project(const Eigen::Vector3d& p_camera, Eigen::Vector2d* uv, double margin_px = 0.0) const;

  /// Undistorts a pixel into normalised coordinates (x/z, y/z): Gauss-Newton on the forward model
  /// (kRadTan), Newton on theta (kKannalaBrandt). Returns false if it did not converge to 1e-9 px
  /// or the result lies beyond the gate.
  bool Unproject(const Eigen::Vector2d& uv, Eigen::Vector2d* xy_normalized) const;
  /// The same, starting Newton from `start` (e.g. a neighbouring pixel's solution: two or three
  /// steps instead of a cold start). Falls back to the cold start if that does not converge.
  bool Unproject(const Eigen::Vector2d& uv, const Eigen::Vector2d& start,
                 Eigen::Vector2d* xy_normalized) const;

  /// Largest undistorted radius (normalised units) the gate accepts.
  double max_undistorted_radius() const { return max_radius_; }

 private:
  Eigen::Matrix2d RadTanJacobian(const Eigen::Vector2d& xy) const;
  bool RadTanNewton(const Eigen::Vector2d& uv, Eigen::Vector2d xy,
                    Eigen::Vector2d* xy_normalized) const;
  CameraIntrinsics intrinsics_;
  double max_radius_ = 0.0;
  double max_theta_ = 0.0;  ///< kKannalaBrandt: largest angle off-axis the gate accepts, radians
};

}  // namespace calibd
