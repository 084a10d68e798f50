#include "calibd/core/camera/camera_model.hpp"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <sstream>

namespace calibd {

bool CameraIntrinsics::IsValid(std::string* error) const {
  std::ostringstream why;
  if (width <= 0 || height <= 0)
    why << "width/height must be positive";
  else if (!(fx > 0.0 && std::isfinite(fx)) || !(fy > 0.0 && std::isfinite(fy)))
    why << "fx/fy must be positive and finite";
  else if (!(cx >= 0.0 && cx < width && cy >= 0.0 && cy < height))
    why << "cx/cy must lie inside the image";
  else if (!std::isfinite(k1) || !std::isfinite(k2) || !std::isfinite(p1) || !std::isfinite(p2) ||
           !std::isfinite(k3) || !std::isfinite(k4))
    why << "distortion coefficients must be finite";
  else if (model != DistortionModel::kRadTan && model != DistortionModel::kKannalaBrandt)
    why << "model: unknown distortion model";
  // A coefficient the model does not use is most likely a config that mixes the two models.
  else if (model == DistortionModel::kRadTan && k4 != 0.0)
    why << "k4 is used only by the Kannala-Brandt model and must be 0 for radial-tangential";
  else if (model == DistortionModel::kKannalaBrandt && (p1 != 0.0 || p2 != 0.0))
    why << "p1/p2 must be 0 for the Kannala-Brandt model (it has no tangential terms)";
  if (why.tellp() == 0) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

constexpr double kPi = 3.14159265358979323846;

// Derivative of the radial map d(r) = r (1 + k1 r^2 + k2 r^4 + k3 r^6).
double RadialSlope(const CameraIntrinsics& c, double r) {
  const double r2 = r * r;
  return 1.0 + r2 * (3.0 * c.k1 + r2 * (5.0 * c.k2 + r2 * 7.0 * c.k3));
}

// Kannala-Brandt theta_d(theta) = theta (1 + k1 t^2 + k2 t^4 + k3 t^6 + k4 t^8) and its derivative.
double KbThetaD(const CameraIntrinsics& c, double theta) {
  const double t2 = theta * theta;
  return theta * (1.0 + t2 * (c.k1 + t2 * (c.k2 + t2 * (c.k3 + t2 * c.k4))));
}
double KbSlope(const CameraIntrinsics& c, double theta) {
  const double t2 = theta * theta;
  return 1.0 + t2 * (3.0 * c.k1 + t2 * (5.0 * c.k2 + t2 * (7.0 * c.k3 + t2 * 9.0 * c.k4)));
}

}  // namespace

CameraModel::CameraModel(const CameraIntrinsics& intrinsics) : intrinsics_(intrinsics) {
  const auto& c = intrinsics_;
  const double step = 1e-3;
  if (c.model == DistortionModel::kKannalaBrandt) {
    // Walk theta outward until theta_d stops increasing (fold-over, docs/conventions.md#fold-over)
    // or we reach 90 deg off-axis: z > 0 is required of every projected point.
    const double limit = kPi / 2.0 - step;
    double theta = step;
    for (; theta < limit; theta += step) {
      if (KbSlope(c, theta) <= 0.05) break;
    }
    max_theta_ = std::min(theta - step, limit);
    max_radius_ = std::tan(max_theta_);
    return;
  }
  // Radius that covers the image corners, from the undistorted corner radius with a margin.
  const double corner_x = std::max(c.cx, c.width - 1 - c.cx) / c.fx;
  const double corner_y = std::max(c.cy, c.height - 1 - c.cy) / c.fy;
  const double corner_r = std::hypot(corner_x, corner_y);
  // Walk outward until the radial map stops increasing (fold-over) or we pass twice the corner
  // radius.
  double r = step;
  double limit = 2.0 * corner_r + 0.5;
  for (; r < limit; r += step) {
    if (RadialSlope(c, r) <= 0.05) break;
  }
  max_radius_ = r - step;
}

Eigen::Vector2d CameraModel::DistortToPixel(const Eigen::Vector2d& xy) const {
  const auto& c = intrinsics_;
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  if (c.model == DistortionModel::kKannalaBrandt) {
    // cv::fisheye: x_d = (theta_d / r) x with theta = atan(r); the ratio tends to 1 on the axis.
    const double r = std::sqrt(r2);
    const double scale = r > 1e-12 ? KbThetaD(c, std::atan(r)) / r : 1.0;
    return {c.fx * x * scale + c.cx, c.fy * y * scale + c.cy};
  }
  const double radial = 1.0 + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3));
  const double xd = x * radial + 2.0 * c.p1 * x * y + c.p2 * (r2 + 2.0 * x * x);
  const double yd = y * radial + c.p1 * (r2 + 2.0 * y * y) + 2.0 * c.p2 * x * y;
  return {c.fx * xd + c.cx, c.fy * yd + c.cy};
}

bool CameraModel::Project(const Eigen::Vector3d& p_camera, Eigen::Vector2d* uv,
                          double margin_px) const {
  if (!(p_camera.z() > 1e-9)) return false;
  const Eigen::Vector2d xy = p_camera.head<2>() / p_camera.z();
  if (!(xy.norm() <= max_radius_)) return false;  // fold-over gate (docs/conventions.md#fold-over)
  *uv = DistortToPixel(xy);
  const auto& c = intrinsics_;
  return uv->x() >= -0.5 - margin_px && uv->x() <= c.width - 0.5 + margin_px &&
         uv->y() >= -0.5 - margin_px && uv->y() <= c.height - 0.5 + margin_px;
}

// Jacobian of the distorted normalised point w.r.t. the undistorted one for the radial-tangential
// model (DistortToPixel differentiated), in normalised units.
Eigen::Matrix2d CameraModel::RadTanJacobian(const Eigen::Vector2d& xy) const {
  const auto& c = intrinsics_;
  const double x = xy.x(), y = xy.y();
  const double r2 = x * x + y * y;
  const double radial = 1.0 + r2 * (c.k1 + r2 * (c.k2 + r2 * c.k3));
  const double d_radial = c.k1 + r2 * (2.0 * c.k2 + r2 * 3.0 * c.k3);  // d radial / d r2
  Eigen::Matrix2d J;
  J(0, 0) = radial + 2.0 * x * x * d_radial + 2.0 * c.p1 * y + 6.0 * c.p2 * x;
  J(0, 1) = 2.0 * x * y * d_radial + 2.0 * c.p1 * x + 2.0 * c.p2 * y;
  J(1, 0) = J(0, 1);
  J(1, 1) = radial + 2.0 * y * y * d_radial + 6.0 * c.p1 * y + 2.0 * c.p2 * x;
  return J;
}

// Newton on the forward radial-tangential model from `xy`, to 1e-9 px.
bool CameraModel::RadTanNewton(const Eigen::Vector2d& uv, Eigen::Vector2d xy,
                               Eigen::Vector2d* xy_normalized) const {
  const auto& c = intrinsics_;
  for (int it = 0; it < 30; ++it) {
    const Eigen::Vector2d pred = DistortToPixel(xy);
    const Eigen::Vector2d err((pred.x() - uv.x()) / c.fx, (pred.y() - uv.y()) / c.fy);
    if (err.norm() * c.fx < 1e-9) {
      *xy_normalized = xy;
      return xy.norm() <= max_radius_;
    }
    xy -= RadTanJacobian(xy).inverse() * err;
    if (!xy.allFinite()) return false;
  }
  return false;
}

bool CameraModel::Unproject(const Eigen::Vector2d& uv, const Eigen::Vector2d& start,
                            Eigen::Vector2d* xy_normalized) const {
  if (intrinsics_.model == DistortionModel::kRadTan && RadTanNewton(uv, start, xy_normalized))
    return true;
  return Unproject(uv, xy_normalized);
}

bool CameraModel::Unproject(const Eigen::Vector2d& uv, Eigen::Vector2d* xy_normalized) const {
  const auto& c = intrinsics_;
  const Eigen::Vector2d target((uv.x() - c.cx) / c.fx, (uv.y() - c.cy) / c.fy);
  if (c.model == DistortionModel::kKannalaBrandt) {
    // The model is radial only: solve theta_d(theta) = |target| for theta by Newton (monotonic
    // below max_theta_), then scale the direction to radius tan(theta).
    const double theta_d = target.norm();
    if (theta_d < 1e-15) {
      *xy_normalized = Eigen::Vector2d::Zero();
      return true;
    }
    if (!(theta_d <= KbThetaD(c, max_theta_))) return false;
    double theta = std::min(theta_d, max_theta_);
    for (int it = 0; it < 30; ++it) {
      const double f = KbThetaD(c, theta) - theta_d;
      if (std::abs(f) * c.fx < 1e-9) {
        const double r = std::tan(theta);
        *xy_normalized = target * (r / theta_d);
        return theta <= max_theta_ + 1e-12;
      }
      theta = std::clamp(theta - f / KbSlope(c, theta), 0.0, max_theta_);
    }
    return false;
  }
  return RadTanNewton(uv, target, xy_normalized);
}

}  // namespace calibd
