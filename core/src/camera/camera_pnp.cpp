#include "calibd/core/camera/camera_pnp.hpp"

#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

namespace calibd {
namespace {

Pose PoseFromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
    T.translation()(r) = tvec(r);
  }
  return T;
}

// LM in normalised coordinates: the same minimum as in pixels up to the (nearly constant) Jacobian
// of the distortion across one board. Tight tolerance: the pose is exact for exact corners.
void RefineLm(const cv::Mat& object, const cv::Mat& image, cv::Vec3d* rvec, cv::Vec3d* tvec) {
  cv::solvePnPRefineLM(
      object, image, cv::Matx33d::eye(), cv::noArray(), *rvec, *tvec,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-14));
}

// ---- Tag pose: IPPE for a square (Collins & Bartoli 2014) then Levenberg-Marquardt ----
// Fixed-size Eigen only: the camera thread runs this for every tag of every frame and must not
// allocate (OpenCV's solvePnP + solvePnPRefineLM made about 175 heap allocations per tag).
// It computes what SOLVEPNP_IPPE_SQUARE + solvePnPRefineLM computed before (the same two IPPE
// candidates, the one with the smaller reprojection error, refined to the same minimum of the
// normalised reprojection error: test_camera_pnp compares both).

using Corners3 = std::array<Eigen::Vector3d, 4>;
using Corners2 = std::array<Eigen::Vector2d, 4>;

// Sum of squared normalised reprojection errors of the tag corners under (R, t). Like OpenCV's
// (cv::projectPoints) it does not look at the side of the camera: a pose behind it (from a tag
// seen almost edge-on under noise) is still ranked and refined, and rejected by the caller's
// reprojection error in pixels (ReprojectionRmsPx: infinity behind the camera).
double NormalisedSse(const Corners3& p_tag, const Corners2& xy, const Eigen::Matrix3d& R,
                     const Eigen::Vector3d& t) {
  double sse = 0.0;
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3d p = R * p_tag[k] + t;
    sse += (p.head<2>() / p.z() - xy[k]).squaredNorm();
  }
  return std::isnan(sse) ? std::numeric_limits<double>::infinity() : sse;
}

// The homography H (H(2,2) = 1) with H (x_k, y_k, 1)^T ~ (u_k, v_k, 1)^T for four plane points:
// the 8x8 linear system of its eight unknowns (exact for four points in general position).
bool HomographyFromFourPoints(const Corners3& p, const Corners2& uv, double scale,
                              Eigen::Matrix3d* H) {
  Eigen::Matrix<double, 8, 8> A;
  Eigen::Matrix<double, 8, 1> b;
  for (int k = 0; k < 4; ++k) {
    // Plane points scaled to about unit size for the conditioning of the system.
    const double x = p[static_cast<size_t>(k)].x() / scale,
                 y = p[static_cast<size_t>(k)].y() / scale;
    const double u = uv[static_cast<size_t>(k)].x(), v = uv[static_cast<size_t>(k)].y();
    A.row(2 * k) << x, y, 1.0, 0.0, 0.0, 0.0, -u * x, -u * y;
    A.row(2 * k + 1) << 0.0, 0.0, 0.0, x, y, 1.0, -v * x, -v * y;
    b(2 * k) = u;
    b(2 * k + 1) = v;
  }
  // No rank threshold: a tag seen nearly edge-on gives a poorly conditioned but still usable
  // system (the refinement below and the reprojection gate judge the pose).
  const Eigen::Matrix<double, 8, 1> h = A.partialPivLu().solve(b);
  Eigen::Matrix3d H_scaled;
  H_scaled << h(0), h(1), h(2), h(3), h(4), h(5), h(6), h(7), 1.0;
  // Back to plane points in metres: H = H_scaled * diag(1 / scale, 1 / scale, 1).
  *H = H_scaled * Eigen::Vector3d(1.0 / scale, 1.0 / scale, 1.0).asDiagonal();
  return H->allFinite();
}

// The translation minimising the algebraic error of the corners for a rotation R: for each corner
// (R p + t)_xy - uv (R p + t)_z = 0, solved in the least-squares sense (3x3 normal equations).
Eigen::Vector3d TranslationForRotation(const Corners3& p_tag, const Corners2& xy,
                                       const Eigen::Matrix3d& R) {
  Eigen::Matrix3d AtA = Eigen::Matrix3d::Zero();
  Eigen::Vector3d Atb = Eigen::Vector3d::Zero();
  for (size_t k = 0; k < 4; ++k) {
    const Eigen::Vector3d r = R * p_tag[k];
    for (int a = 0; a < 2; ++a) {
      // Row: t_a - uv_a t_z = uv_a r_z - r_a.
      Eigen::Vector3d row = Eigen::Vector3d::Zero();
      row(a) = 1.0;
      row(2) = -xy[k](a);
      AtA += row * row.transpose();
      Atb += row * (xy[k](a) * r.z() - r(a));
    }
  }
  return AtA.ldlt().solve(Atb);
}

// The rotation turning the optical axis onto the line of sight through normalised (x, y): the
// half-way quaternion, as Eigen's Quaterniond::FromTwoVectors computes it. Its branch for
// opposite vectors (a JacobiSVD, most of this file's compile time) cannot be taken here: the line
// of sight has z = 1.
Eigen::Matrix3d TurnOpticalAxisTo(const Eigen::Vector2d& xy) {
  const Eigen::Vector3d z = Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d sight = Eigen::Vector3d(xy.x(), xy.y(), 1.0).normalized();
  const double s = std::sqrt((1.0 + sight.dot(z)) * 2.0);
  Eigen::Quaterniond q;
  q.vec() = z.cross(sight) * (1.0 / s);
  q.w() = s * 0.5;
  return q.toRotationMatrix();
}

// IPPE (Collins & Bartoli, "Infinitesimal Plane-Based Pose Estimation", IJCV 2014, §4): from the
// homography's Jacobian J at the plane origin and the origin's image v, the two rotations whose
// first-order projection matches J (they differ by a reflection of the plane's normal about the
// line of sight); each gets its least-squares translation and the one that reprojects the corners
// better wins.
bool SquarePose(const Corners3& p_tag, const Corners2& xy, double half_side, Eigen::Matrix3d* R_out,
                Eigen::Vector3d* t_out) {
  Eigen::Matrix3d H;
  if (!HomographyFromFourPoints(p_tag, xy, half_side, &H)) return false;
  const Eigen::Vector2d v(H(0, 2), H(1, 2));  // image of the tag centre
  Eigen::Matrix2d J;                          // d(image) / d(plane) at the centre
  J << H(0, 0) - H(2, 0) * H(0, 2), H(0, 1) - H(2, 1) * H(0, 2), H(1, 0) - H(2, 0) * H(1, 2),
      H(1, 1) - H(2, 1) * H(1, 2);
  // R_v turns the optical axis onto the line of sight through v. With R = R_v R', the projection's
  // Jacobian [I | -v] R (first two columns) / t_z becomes B R'_2x2 / t_z, B = ([I | -v] R_v)_2x2
  // (the third column vanishes), so A = B^-1 J = R'_2x2 / t_z: its larger singular value is
  // 1 / t_z and R'_2x2 = A t_z (paper eq. 20-26).
  const Eigen::Matrix3d R_v = TurnOpticalAxisTo(v);
  Eigen::Matrix<double, 2, 3> projection;
  projection << 1.0, 0.0, -v.x(), 0.0, 1.0, -v.y();
  const Eigen::Matrix2d B = (projection * R_v).leftCols<2>();
  if (!(std::fabs(B.determinant()) > 1e-300)) return false;
  const Eigen::Matrix2d A = B.inverse() * J;
  const Eigen::Matrix2d AAt = A * A.transpose();
  const double gamma2 =
      0.5 * (AAt.trace() + std::sqrt((AAt(0, 0) - AAt(1, 1)) * (AAt(0, 0) - AAt(1, 1)) +
                                     4.0 * AAt(0, 1) * AAt(0, 1)));
  const double gamma = std::sqrt(gamma2);
  if (!(gamma > std::numeric_limits<float>::epsilon())) return false;
  const Eigen::Matrix2d R2 = A / gamma;
  // Complete the first two columns of R' to unit vectors orthogonal to each other: their third
  // entries b0, b1 are fixed up to a common sign (b0 b1 = -(column 0 . column 1) of R2).
  const double b0 = std::sqrt(std::max(0.0, 1.0 - R2.col(0).squaredNorm()));
  double b1 = std::sqrt(std::max(0.0, 1.0 - R2.col(1).squaredNorm()));
  if (-R2.col(0).dot(R2.col(1)) < 0.0) b1 = -b1;
  double best = std::numeric_limits<double>::infinity();
  for (const double sign : {1.0, -1.0}) {
    const Eigen::Vector3d c0(R2(0, 0), R2(1, 0), sign * b0);
    const Eigen::Vector3d c1(R2(0, 1), R2(1, 1), sign * b1);
    Eigen::Matrix3d R_prime;
    R_prime << c0, c1, c0.cross(c1);
    const Eigen::Matrix3d R = R_v * R_prime;
    const Eigen::Vector3d t = TranslationForRotation(p_tag, xy, R);
    const double sse = NormalisedSse(p_tag, xy, R, t);
    if (sse < best) {
      best = sse;
      *R_out = R;
      *t_out = t;
    }
  }
  return std::isfinite(best);
}

// Levenberg-Marquardt on the normalised reprojection error of the 4 corners over the pose (the
// rotation updated on the left, R <- exp([w]x) R), to convergence at machine precision: the
// corners are exact for an exact pose, so the minimum is sharp.
void RefinePose(const Corners3& p_tag, const Corners2& xy, Eigen::Matrix3d* R, Eigen::Vector3d* t) {
  double cost = NormalisedSse(p_tag, xy, *R, *t);
  if (!std::isfinite(cost)) return;
  double lambda = 1e-3;
  for (int iteration = 0; iteration < 50 && cost > 0.0; ++iteration) {
    Eigen::Matrix<double, 6, 6> JtJ = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> Jtr = Eigen::Matrix<double, 6, 1>::Zero();
    for (size_t k = 0; k < 4; ++k) {
      const Eigen::Vector3d Rp = *R * p_tag[k];
      const Eigen::Vector3d p = Rp + *t;
      const double iz = 1.0 / p.z();
      const Eigen::Vector2d r = p.head<2>() * iz - xy[k];
      Eigen::Matrix<double, 2, 3> d_proj;  // d(x/z, y/z) / dp
      d_proj << iz, 0.0, -p.x() * iz * iz, 0.0, iz, -p.y() * iz * iz;
      Eigen::Matrix3d skew;  // dp / dw = -[R p]x
      skew << 0.0, Rp.z(), -Rp.y(), -Rp.z(), 0.0, Rp.x(), Rp.y(), -Rp.x(), 0.0;
      Eigen::Matrix<double, 2, 6> Jk;
      Jk << d_proj * skew, d_proj;
      JtJ.noalias() += Jk.transpose() * Jk;
      Jtr.noalias() += Jk.transpose() * r;
    }
    bool improved = false;
    Eigen::Matrix<double, 6, 1> step = Eigen::Matrix<double, 6, 1>::Zero();
    while (lambda < 1e12) {
      Eigen::Matrix<double, 6, 6> damped = JtJ;
      damped.diagonal() *= 1.0 + lambda;
      step = damped.ldlt().solve(-Jtr);
      const double angle = step.head<3>().norm();
      Eigen::Matrix3d R_new = *R;
      if (angle > 0.0)
        R_new = Eigen::AngleAxisd(angle, step.head<3>() / angle).toRotationMatrix() * *R;
      const Eigen::Vector3d t_new = *t + step.tail<3>();
      const double new_cost = NormalisedSse(p_tag, xy, R_new, t_new);
      if (new_cost < cost) {
        *R = R_new;
        *t = t_new;
        cost = new_cost;
        lambda = std::max(lambda * 0.1, 1e-12);
        improved = true;
        break;
      }
      lambda *= 10.0;
    }
    if (!improved || step.norm() <= 1e-15 * (1.0 + t->norm())) break;
  }
}

}  // namespace

double ReprojectionRmsPx(const CameraModel& model, const Pose& T_camera_board,
                         const Eigen::Vector3d* points_board, const Eigen::Vector2d* points_px,
                         size_t n) {
  if (n == 0) return 0.0;
  double sum = 0.0;
  for (size_t i = 0; i < n; ++i) {
    const Eigen::Vector3d p_c = T_camera_board * points_board[i];
    if (!(p_c.z() > 1e-9)) return std::numeric_limits<double>::infinity();
    sum += (model.DistortToPixel(p_c.head<2>() / p_c.z()) - points_px[i]).squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(n));
}

bool EstimateTagPose(const CameraModel& model, const BoardGeometry& board,
                     const std::array<Eigen::Vector2d, 4>& corners_px, Pose* T_camera_board,
                     double* reprojection_rms_px) {
  // The tag's corners in its own frame (centred, z = 0: what IPPE needs) and undistorted.
  const auto corners_b = board.TagCornersInBoard();
  const Eigen::Vector3d offset(board.tag_offset_m.x(), board.tag_offset_m.y(), 0.0);
  Corners3 p_tag;
  Corners2 xy;
  for (size_t k = 0; k < 4; ++k) {
    p_tag[k] = corners_b[k] - offset;
    if (!model.Unproject(corners_px[k], &xy[k])) return false;
  }
  const double half_side = board.tag_size_m / 2.0;
  Eigen::Matrix3d R_camera_tag;
  Eigen::Vector3d t_camera_tag;
  if (!SquarePose(p_tag, xy, half_side, &R_camera_tag, &t_camera_tag)) return false;
  RefinePose(p_tag, xy, &R_camera_tag, &t_camera_tag);
  // T_camera_board = T_camera_tag * T_tag_board, the tag centre at `offset` in B.
  *T_camera_board = Pose::Identity();
  T_camera_board->linear() = R_camera_tag;
  T_camera_board->translation() = t_camera_tag - R_camera_tag * offset;
  if (!T_camera_board->matrix().allFinite()) return false;
  if (reprojection_rms_px) {
    *reprojection_rms_px =
        ReprojectionRmsPx(model, *T_camera_board, corners_b.data(), corners_px.data(), 4);
  }
  return true;
}

bool EstimatePlanarPose(const CameraModel& model, const std::vector<Eigen::Vector3d>& points_board,
                        const std::vector<Eigen::Vector2d>& points_px, Pose* T_camera_board,
                        double* reprojection_rms_px) {
  const size_t n = points_board.size();
  if (n < 4 || points_px.size() != n) return false;
  cv::Mat object_m(static_cast<int>(n), 1, CV_64FC3);
  cv::Mat image_m(static_cast<int>(n), 1, CV_64FC2);
  for (size_t i = 0; i < n; ++i) {
    Eigen::Vector2d xy;
    if (!model.Unproject(points_px[i], &xy)) return false;
    const int r = static_cast<int>(i);
    object_m.at<cv::Vec3d>(r) =
        cv::Vec3d(points_board[i].x(), points_board[i].y(), points_board[i].z());
    image_m.at<cv::Vec2d>(r) = cv::Vec2d(xy.x(), xy.y());
  }
  cv::Vec3d rvec, tvec;
  if (!cv::solvePnP(object_m, image_m, cv::Matx33d::eye(), cv::noArray(), rvec, tvec, false,
                    cv::SOLVEPNP_ITERATIVE))
    return false;
  RefineLm(object_m, image_m, &rvec, &tvec);
  *T_camera_board = PoseFromRvecTvec(rvec, tvec);
  if (!T_camera_board->matrix().allFinite()) return false;
  if (reprojection_rms_px) {
    *reprojection_rms_px =
        ReprojectionRmsPx(model, *T_camera_board, points_board.data(), points_px.data(), n);
  }
  return true;
}

}  // namespace calibd
