#pragma once
// Test helper: HtmlReportInput values for an accepted (updated) and a rejected calibration, with
// a demo-sized set of correspondences (3 boards, 200 frame pairs, 6-30 m) and overlay pictures.

#include <cmath>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>

#include "calibd/core/common/geometry.hpp"
#include "html_report.hpp"

namespace calibd::testing {

// A picture of `width` x `height`: a gradient with a few shapes (`noise`: random pixels instead,
// which PNG cannot compress: the size of a real camera frame's overlay).
inline tools::ReportImage TestPicture(const std::string& caption, int width, int height,
                                      bool noise) {
  cv::Mat bgr(height, width, CV_8UC3);
  if (noise) {
    cv::randu(bgr, cv::Scalar::all(0), cv::Scalar::all(255));
  } else {
    for (int r = 0; r < height; ++r)
      bgr.row(r).setTo(cv::Scalar(255 * r / height, 128, 255 - 255 * r / height));
    cv::circle(bgr, {width / 2, height / 2}, height / 4, cv::Scalar(0, 255, 0), 3);
  }
  tools::ReportImage image;
  image.caption = caption;
  cv::imencode(".png", bgr, image.png);
  return image;
}

inline tools::HtmlReportInput AcceptedReportInput(bool big_pictures = false) {
  tools::HtmlReportInput in;
  CalibrationOutcome& out = in.outcome;
  out.verdict = CalibrationOutcome::Verdict::kUpdated;
  out.detail = "the extrinsic changed by 5.000 deg / 0.050 m";
  out.solved = true;
  Eigen::Matrix3d R_camera_lidar;
  R_camera_lidar << 0, -1, 0, 0, 0, -1, 1, 0, 0;  // LiDAR x forward -> camera z forward
  out.T_camera_lidar.linear() = R_camera_lidar * RotationFromRpy(0.01, -0.02, 0.03);
  out.T_camera_lidar.translation() = Eigen::Vector3d(0.05, -0.32, -0.11);
  out.prior_T_camera_lidar.linear() = R_camera_lidar;
  out.prior_T_camera_lidar.translation() = Eigen::Vector3d(0.02, -0.30, -0.15);
  out.delta_rotation_deg = 5.0;
  out.delta_translation_m = 0.05;
  QualityFigures& q = out.quality;
  q.reprojection_mean_px = 3.23;
  q.reprojection_p95_px = 6.76;
  q.residual_rms_m = 0.0259;
  q.frames_used = 200;
  q.boards_used = 600;
  q.min_distance_m = 5.61;
  q.max_distance_m = 30.12;
  q.image_coverage = 0.5;
  q.rotation_sigma_deg = 0.004;
  q.translation_sigma_m = 0.001;
  q.plane_conditioning = 9e-5;
  q.rotation_spread_deg = 0.02;
  q.translation_spread_m = 0.003;
  q.rotation_bound_deg = 0.12;
  q.translation_bound_m = 0.015;
  out.grid.best_count = 5200;
  out.grid.prior_count = 800;
  in.board_names = {"board 0 (tag36h11 #0)", "board 1 (tag36h11 #1)", "board 2 (tag36h11 #2)"};
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.8);
  for (int frame = 0; frame < 200; ++frame) {
    const double d = 6.0 + 24.0 * (0.5 - 0.5 * std::cos(frame * 2.0 * M_PI / 200.0));
    for (int b = 0; b < 3; ++b)
      in.reprojection.push_back({b, d + b * 0.4, std::abs(1.5 + 0.1 * d + 0.3 * b + noise(rng))});
  }
  in.reprojection.push_back({1, 12.0, std::nan("")});  // a board whose fit failed
  const int w = big_pictures ? 1920 : 480, h = big_pictures ? 960 : 240;
  for (int pair : {0, 50, 100, 150})
    in.images.push_back(TestPicture(
        "pair " + std::to_string(pair) + ": LiDAR points through the result", w, h, big_pictures));
  in.provenance.software_version = "calibd 0.1.0";
  in.provenance.input_path = "/data/session.lcmlog";
  in.provenance.config_path = "/data/calib.yaml";
  in.provenance.config_sha256 = tools::Sha256Hex("boards: []\n");
  in.provenance.method = "direct";
  in.provenance.generated_unix_s = 1700000000;
  in.provenance.camera_frames = in.provenance.lidar_frames = in.provenance.pairs = 200;
  in.provenance.camera_boards = in.provenance.lidar_boards = 600;
  return in;
}

inline tools::HtmlReportInput RejectedReportInput() {
  tools::HtmlReportInput in = AcceptedReportInput();
  in.outcome.verdict = CalibrationOutcome::Verdict::kRejected;
  in.outcome.reason = Reason::kHighReprojectionError;
  in.outcome.detail = "mean 9.40 px above 8.00 px";
  in.outcome.quality.reprojection_mean_px = 9.4;
  for (auto& r : in.reprojection) r.mean_px *= 3.0;
  return in;
}

}  // namespace calibd::testing
