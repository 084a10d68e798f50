#pragma once
// Test helper: simulate a session and run the real camera and LiDAR detectors on some of its frame
// pairs, recording the observations the engine works on.

#include <memory>
#include <opencv2/core.hpp>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/core/lidar/range_image.hpp"
#include "calibd/core/session/session_observations.hpp"
#include "session.hpp"

namespace calibd::testing {

struct RecordedSession {
  sim::SessionSimulator session;
  SessionObservations obs;
  RangeImage projection;  ///< SessionProjection of the session's LiDAR model
  CalibConfig config;     ///< what a user would have written (prior = the simulator's prior)
};

/// Frames first_frame, first_frame + stride, ... (`count` of them) of a session with `options`;
/// the LiDAR detector and the range image with `configured` when given (a user's wrong model),
/// else the simulated LiDAR's; the detectors with the user's config as `edit_config` changes it
/// when given (a user's wrong boards).
inline std::unique_ptr<RecordedSession> Record(const sim::SessionOptions& options, int count,
                                               int stride, int first_frame = 0,
                                               const LidarModel* configured = nullptr,
                                               void (*edit_config)(CalibConfig*) = nullptr) {
  auto r = std::make_unique<RecordedSession>();
  std::string error;
  if (!r->session.Init(options, &error)) {
    ADD_FAILURE() << error;
    return r;
  }
  r->config = r->session.UserConfig();
  if (edit_config != nullptr) edit_config(&r->config);
  const auto& boards = r->config.boards;
  CameraDetector camera(CameraDetectorConfig{}, options.camera, boards);
  const LidarModel& model = configured ? *configured : r->session.lidar_model();
  if (configured) r->config.lidar_model = configured->name;
  LidarDetector lidar(LidarDetectorConfig{}, model, boards);
  EXPECT_TRUE(camera.ok()) << camera.error();
  EXPECT_TRUE(lidar.ok()) << lidar.error();
  r->projection = SessionProjection(model);
  r->obs.Reserve(count, static_cast<int>(boards.size()) + 4, 4096);
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  CameraDetections cd;
  LidarDetections ld;
  for (int k = 0; k < count; ++k) {
    r->session.SimulateFrame(first_frame + stride * k, &image, &scan, &truth);
    camera.Detect(ImageView{image.data, image.cols, image.rows, static_cast<int>(image.step[0])},
                  &cd);
    lidar.Detect(PointCloudView{scan.x.data(), scan.y.data(), scan.z.data(),
                                r->session.lidar_model().has_rings ? scan.ring.data() : nullptr,
                                scan.size(), scan.time_offset_us.data()},
                 &ld);
    EXPECT_TRUE(r->obs.AddFrame(cd, ld, boards, FrameTimes{truth.camera_utime, truth.lidar_utime}));
  }
  return r;
}

}  // namespace calibd::testing
