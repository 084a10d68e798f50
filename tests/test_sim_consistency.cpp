// End-to-end consistency of the simulated sensors: the board pose that a camera-only pipeline gets
// from the rendered image (AprilTag + PnP) and the LiDAR points mapped through the true
// T_camera_lidar must describe the same board. This is what calibration relies on: if the two
// sensors disagreed, no calibration could recover the truth.

#include <gtest/gtest.h>

#include <algorithm>
#include <cstdio>
#include <opencv2/calib3d.hpp>

#include "session.hpp"
#include "tag_detector.hpp"

namespace calibd::sim {
namespace {

Pose SolveBoardPose(const BoardGeometry& g, const testing::Detection& det,
                    const CameraIntrinsics& k) {
  std::vector<cv::Point3d> object;
  std::vector<cv::Point2d> image;
  // SOLVEPNP_IPPE_SQUARE needs its own corner order: (-s,+s), (+s,+s), (+s,-s), (-s,-s), i.e.
  // AprilTag's order (bottom-left first, counter-clockwise) reversed.
  const auto corners = g.TagCornersInBoard();
  for (int i : {3, 2, 1, 0}) {
    object.emplace_back(corners[i].x(), corners[i].y(), corners[i].z());
    image.emplace_back(det.corners[i].x(), det.corners[i].y());
  }
  const cv::Matx33d K(k.fx, 0, k.cx, 0, k.fy, k.cy, 0, 0, 1);
  const std::vector<double> dist{k.k1, k.k2, k.p1, k.p2, k.k3};
  cv::Vec3d rvec, tvec;
  EXPECT_TRUE(cv::solvePnP(object, image, K, dist, rvec, tvec, false, cv::SOLVEPNP_IPPE_SQUARE));
  cv::Matx33d R;
  cv::Rodrigues(rvec, R);
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 3; ++c) T.linear()(r, c) = R(r, c);
  T.translation() = Eigen::Vector3d(tvec[0], tvec[1], tvec[2]);
  return T;
}

class SimConsistencyTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SimConsistencyTest, CameraBoardPoseAndLidarBoardPointsAgreeThroughTheTrueExtrinsic) {
  SessionOptions o;
  o.lidar_model = GetParam();
  o.trajectory.mode = "static";
  o.trajectory.static_distance_m = 8.0;
  o.trajectory.duration_s = 0.1;
  SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  cv::Mat image;
  LidarScan scan;
  FrameTruth truth;
  s.SimulateFrame(0, &image, &scan, &truth);

  const auto detections = testing::TagDetector().Detect(image);
  const auto& geometries = s.workshop().geometries;
  int boards_checked = 0;
  for (size_t b = 0; b < geometries.size(); ++b) {
    const auto it = std::find_if(detections.begin(), detections.end(),
                                 [&](const auto& d) { return d.id == geometries[b].tag_id; });
    ASSERT_NE(it, detections.end()) << "tag " << geometries[b].tag_id << " not detected";
    const Pose T_camera_board = SolveBoardPose(geometries[b], *it, o.camera);
    // Camera-only board pose vs the truth.
    EXPECT_LT((T_camera_board.translation() - truth.boards[b].T_camera_board.translation()).norm(),
              0.03);
    EXPECT_LT(RotationAngle(T_camera_board.linear(), truth.boards[b].T_camera_board.linear()) *
                  180.0 / M_PI,
              1.0);
    // LiDAR board points through the true extrinsic land on that board.
    const Pose T_board_lidar = T_camera_board.inverse() * s.T_camera_lidar();
    std::vector<double> abs_z;
    int outside = 0;
    for (int idx : truth.boards[b].lidar_point_indices) {
      const Eigen::Vector3d p_board =
          T_board_lidar * Eigen::Vector3d(scan.x[idx], scan.y[idx], scan.z[idx]);
      abs_z.push_back(std::abs(p_board.z()));
      if (std::abs(p_board.x()) > geometries[b].width_m / 2 + 0.03 ||
          std::abs(p_board.y()) > geometries[b].height_m / 2 + 0.03)
        ++outside;
    }
    ASSERT_GT(abs_z.size(), 100u);
    std::sort(abs_z.begin(), abs_z.end());
    const double median = abs_z[abs_z.size() / 2];
    const double p95 = abs_z[abs_z.size() * 95 / 100];
    std::printf(
        "%s board %zu: %zu points, |z_board| median %.4f m, p95 %.4f m, PnP error %.4f m\n",
        GetParam().c_str(), b, abs_z.size(), median, p95,
        (T_camera_board.translation() - truth.boards[b].T_camera_board.translation()).norm());
    EXPECT_LT(median, 0.025) << "board " << b;  // 2 cm range noise + PnP depth error
    EXPECT_LT(p95, 0.07) << "board " << b;
    EXPECT_LE(outside, static_cast<int>(abs_z.size()) / 50) << "board " << b;
    ++boards_checked;
  }
  EXPECT_EQ(boards_checked, 3);
}

INSTANTIATE_TEST_SUITE_P(Lidars, SimConsistencyTest, ::testing::Values("ot128", "m1", "falcon"));

}  // namespace
}  // namespace calibd::sim
