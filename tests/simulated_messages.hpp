#pragma once
/// \file
/// Frames of a simulated drive as the sensors send them (camera_frame_t mono8, lidar_frame_t),
/// for the tests that feed the agent's intake message by message.

#include <string>
#include <vector>

#include <gtest/gtest.h>

#include "lcm_output.hpp"
#include "session.hpp"

namespace calibd::testing {

struct SimulatedMessages {
  std::vector<camera_frame_t> camera;
  std::vector<lidar_frame_t> lidar;
  CalibConfig config;   ///< the user config the simulator writes for the drive
  Pose T_camera_lidar;  ///< the truth
  LidarModel lidar_model;
  int drive_frames = 0;  ///< frames in the whole drive (the simulator's num_frames)
};

/// Frames first, first + stride, ... (`count` of them) of the drive `options` describes.
inline SimulatedMessages SimulateMessages(const sim::SessionOptions& options, int count,
                                          int stride = 1, int first = 0) {
  SimulatedMessages out;
  sim::SessionSimulator sim;
  std::string error;
  EXPECT_TRUE(sim.Init(options, &error)) << error;
  EXPECT_GE(sim.num_frames(), first + (count - 1) * stride + 1);
  out.drive_frames = sim.num_frames();
  out.config = sim.UserConfig();
  out.T_camera_lidar = sim.T_camera_lidar();
  out.lidar_model = sim.lidar_model();
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  for (int k = 0; k < count; ++k) {
    sim.SimulateFrame(first + k * stride, &image, &scan, &truth);
    camera_frame_t c;
    EXPECT_TRUE(sim::ToCameraMessage(image, truth.camera_utime, out.config.camera_id,
                                     camera_frame_t::ENCODING_MONO8, 90, &c));
    lidar_frame_t l;
    sim::ToLidarMessage(scan, truth.lidar_utime, out.config.lidar_id, &l);
    out.camera.push_back(std::move(c));
    out.lidar.push_back(std::move(l));
  }
  return out;
}

}  // namespace calibd::testing
