#include "calibd/core/camera_pnp.hpp"

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
  // SOLVEPNP_IPPE_SQUARE wants the tag centred at the origin, corners in its order (-s,+s),
  // (+s,+s), (+s,-s), (-s,-s): AprilTag's order reversed (docs/conventions.md#ippe-square).
  // Stack buffers wrapped by cv::Mat: no heap for the inputs.
  const auto corners_b = board.TagCornersInBoard();
  const Eigen::Vector3d offset(board.tag_offset_m.x(), board.tag_offset_m.y(), 0.0);
  double object[4][3];
  double image[4][2];
  for (size_t k = 0; k < 4; ++k) {
    const size_t j = 3 - k;
    const Eigen::Vector3d p = corners_b[j] - offset;
    Eigen::Vector2d xy;
    if (!model.Unproject(corners_px[j], &xy)) return false;
    for (int a = 0; a < 3; ++a) object[k][a] = p(a);
    image[k][0] = xy.x();
    image[k][1] = xy.y();
  }
  const cv::Mat object_m(4, 1, CV_64FC3, object);
  const cv::Mat image_m(4, 1, CV_64FC2, image);
  cv::Vec3d rvec, tvec;
  if (!cv::solvePnP(object_m, image_m, cv::Matx33d::eye(), cv::noArray(), rvec, tvec, false,
                    cv::SOLVEPNP_IPPE_SQUARE))
    return false;
  RefineLm(object_m, image_m, &rvec, &tvec);
  // T_camera_board = T_camera_tag * T_tag_board, the tag centre at `offset` in B.
  Pose T_tag_board = Pose::Identity();
  T_tag_board.translation() = -offset;
  *T_camera_board = PoseFromRvecTvec(rvec, tvec) * T_tag_board;
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
