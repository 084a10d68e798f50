#include "calibd/core/solve/indirect_optimizer.hpp"

#include <opencv2/calib3d.hpp>

#include "calibd/core/solve/board_fit.hpp"

namespace calibd {

IndirectResult OptimizeIndirect(const std::vector<BoardGeometry>& boards, const ObservationSet& set,
                                const CameraModel& camera, const Pose& T_camera_lidar_init,
                                const IndirectOptimizerConfig& config) {
  IndirectResult result;
  result.T_camera_lidar = T_camera_lidar_init;
  const Pose T_lidar_camera = T_camera_lidar_init.inverse();
  std::vector<cv::Point3d> object;  // fitted tag corners, LiDAR frame
  std::vector<cv::Point2d> image;   // detected corners, undistorted normalised coordinates
  for (const auto& o : set.observations) {
    if (o.board_index < 0 || o.board_index >= static_cast<int>(boards.size())) continue;
    const BoardGeometry& g = boards[o.board_index];
    const BoardFitResult fit = FitBoardPose(set.points.data() + o.first_point, o.num_points,
                                            g.width_m / 2.0, g.height_m / 2.0, config.alpha_m,
                                            config.huber_m, T_lidar_camera * o.T_camera_board);
    if (!fit.usable) continue;
    ++result.boards_fitted;
    const auto corners = g.TagCornersInBoard();
    for (int c = 0; c < 4; ++c) {
      Eigen::Vector2d xy;
      if (!camera.Unproject(o.corners_px[c], &xy)) continue;
      const Eigen::Vector3d p = fit.T_lidar_board * corners[c];
      object.emplace_back(p.x(), p.y(), p.z());
      image.emplace_back(xy.x(), xy.y());
    }
  }
  result.correspondences = static_cast<int>(object.size());
  if (object.size() < 6) {
    result.reason = "fewer than 6 fitted corners";
    return result;
  }
  // PnP in normalised coordinates (identity K, no distortion): one path for every camera model.
  const Eigen::AngleAxisd aa(T_camera_lidar_init.linear());
  const Eigen::Vector3d w = aa.angle() * aa.axis();
  cv::Mat rvec = (cv::Mat_<double>(3, 1) << w.x(), w.y(), w.z());
  const Eigen::Vector3d t0 = T_camera_lidar_init.translation();
  cv::Mat tvec = (cv::Mat_<double>(3, 1) << t0.x(), t0.y(), t0.z());
  std::vector<int> inliers;
  const double threshold = config.ransac_threshold_px / camera.intrinsics().fx;
  if (!cv::solvePnPRansac(object, image, cv::Mat::eye(3, 3, CV_64F), cv::noArray(), rvec, tvec,
                          true, config.ransac_iterations, static_cast<float>(threshold), 0.999,
                          inliers, cv::SOLVEPNP_ITERATIVE)) {
    result.reason = "PnP RANSAC found no consistent solution";
    return result;
  }
  const Eigen::Vector3d rv(rvec.at<double>(0), rvec.at<double>(1), rvec.at<double>(2));
  Pose T = Pose::Identity();
  if (rv.norm() > 0.0)
    T.linear() = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
  T.translation() = Eigen::Vector3d(tvec.at<double>(0), tvec.at<double>(1), tvec.at<double>(2));
  result.T_camera_lidar = T;
  result.inliers = static_cast<int>(inliers.size());
  double sum = 0.0;
  for (int i : inliers) {
    Eigen::Vector2d uv;
    const Eigen::Vector3d p = T * Eigen::Vector3d(object[i].x, object[i].y, object[i].z);
    if (!camera.Project(p, &uv, 1e6)) continue;
    const Eigen::Vector2d obs = camera.DistortToPixel({image[i].x, image[i].y});
    sum += (uv - obs).norm();
  }
  result.reprojection_mean_px = inliers.empty() ? 0.0 : sum / static_cast<double>(inliers.size());
  result.usable = result.inliers >= 6;
  if (!result.usable) result.reason = "too few RANSAC inliers";
  return result;
}

}  // namespace calibd
