// EstimateTagPose (IPPE + Levenberg-Marquardt in fixed-size Eigen, no heap) against the OpenCV
// calls it replaced: cv::solvePnP(SOLVEPNP_IPPE_SQUARE) then cv::solvePnPRefineLM, kept here as the
// oracle. Random tags at 2-40 m, turned up to 70 deg, with 0, 0.2 and 1 px corner noise, for both
// distortion models: the same pose (to far below the pose noise) and the same reprojection error.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <random>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/camera/camera_pnp.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"

namespace calibd {
namespace {

// The previous implementation of EstimateTagPose (OpenCV), as the oracle.
bool OpenCvTagPose(const CameraModel& model, const BoardGeometry& board,
                   const std::array<Eigen::Vector2d, 4>& corners_px, Pose* T_camera_board) {
  // SOLVEPNP_IPPE_SQUARE's corner order is AprilTag's reversed (docs/conventions.md#ippe-square).
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
  cv::solvePnPRefineLM(
      object_m, image_m, cv::Matx33d::eye(), cv::noArray(), rvec, tvec,
      cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 50, 1e-14));
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Pose T_camera_tag = Pose::Identity();
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) T_camera_tag.linear()(r, c) = R(r, c);
    T_camera_tag.translation()(r) = tvec(r);
  }
  Pose T_tag_board = Pose::Identity();
  T_tag_board.translation() = -offset;
  *T_camera_board = T_camera_tag * T_tag_board;
  return true;
}

CameraIntrinsics KannalaBrandtCamera() {
  CameraIntrinsics k;
  k.model = DistortionModel::kKannalaBrandt;
  k.fx = k.fy = 1400.0;
  k.k1 = 0.05;
  k.k2 = -0.01;
  k.k3 = 0.002;
  k.k4 = -0.0005;
  k.p1 = k.p2 = 0.0;
  return k;
}

TEST(CameraPnpTest, TagPoseMatchesOpenCvIppeSquareAndRefineLm) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> unit(-1.0, 1.0);
  std::uniform_real_distribution<double> distance(2.0, 40.0);
  BoardGeometry board;
  board.tag_offset_m = {0.03, -0.02};  // the tag off the board centre exercises T_tag_board
  int compared = 0, opencv_failed = 0;
  double max_translation_m = 0.0, max_rotation_rad = 0.0, max_rms_px = 0.0;
  for (const CameraIntrinsics& k : {CameraIntrinsics{}, KannalaBrandtCamera()}) {
    const CameraModel model(k);
    for (const double noise_px : {0.0, 0.2, 1.0}) {
      std::normal_distribution<double> noise(0.0, noise_px);
      for (int trial = 0; trial < 300; ++trial) {
        // Facing the camera (z_B ~ -z_C), turned up to 70 deg in yaw and 40 in pitch and roll.
        Eigen::Matrix3d R_facing;
        R_facing << 1, 0, 0, 0, -1, 0, 0, 0, -1;
        Pose T_true = Pose::Identity();
        T_true.linear() =
            RotationFromRpy(0.7 * unit(rng), 1.2 * unit(rng), 0.7 * unit(rng)) * R_facing;
        const double z = distance(rng);
        T_true.translation() = Eigen::Vector3d(0.4 * z * unit(rng), 0.2 * z * unit(rng), z);
        std::array<Eigen::Vector2d, 4> corners;
        bool visible = true;
        for (size_t i = 0; i < 4; ++i) {
          visible = visible && model.Project(T_true * board.TagCornersInBoard()[i], &corners[i]);
          if (noise_px > 0.0) corners[i] += Eigen::Vector2d(noise(rng), noise(rng));
        }
        if (!visible) continue;
        Pose T_cv;
        if (!OpenCvTagPose(model, board, corners, &T_cv)) {
          ++opencv_failed;
          continue;
        }
        Pose T_est;
        double rms = -1.0;
        ASSERT_TRUE(EstimateTagPose(model, board, corners, &T_est, &rms));
        const double rms_cv =
            ReprojectionRmsPx(model, T_cv, board.TagCornersInBoard().data(), corners.data(), 4);
        ++compared;
        const double dt = (T_est.translation() - T_cv.translation()).norm() / z;
        const double dr = RotationAngle(T_est.linear(), T_cv.linear());
        max_translation_m = std::max(max_translation_m, dt);
        max_rotation_rad = std::max(max_rotation_rad, dr);
        // Both behind the camera (a tag seen almost edge-on under noise): infinite, and rejected.
        if (std::isinf(rms) && std::isinf(rms_cv)) continue;
        max_rms_px = std::max(max_rms_px, std::fabs(rms - rms_cv));
        // Far below the pose noise of 0.2 px (test_camera_detector: about 1e-3 x the distance).
        EXPECT_LT(dt, 1e-7) << "trial " << trial << " noise " << noise_px << " at " << z << " m";
        EXPECT_LT(dr, 1e-7) << "trial " << trial << " noise " << noise_px << " at " << z << " m";
        EXPECT_LT(std::fabs(rms - rms_cv), 1e-6) << "trial " << trial;
      }
    }
  }
  std::printf(
      "[ pnp      ] %d poses compared with OpenCV (%d it could not solve): largest difference "
      "%.2e of the distance, %.2e rad, %.2e px rms\n",
      compared, opencv_failed, max_translation_m, max_rotation_rad, max_rms_px);
  EXPECT_GT(compared, 1500);
}

}  // namespace
}  // namespace calibd
