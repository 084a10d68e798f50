// The camera's time offset measured and corrected on a whole simulated drive: the
// default drive (ot128, 3 boards, 6-30 m and back, 20 s) at 5 Hz with the camera 30 ms late and
// each pair stamped with one time, its LiDAR sweep's start (pairs matched by file name), through
// the real detectors and engine; and refused when the offset is beyond what is corrected for.

#include <gtest/gtest.h>

#include <cstdio>

#include "calib_experiments.hpp"
#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/lidar/lidar_model.hpp"
#include "session.hpp"

namespace calibd::bench {
namespace {

TEST(TimeOffsetDriveTest, ACameraThirtyMsLateOnOneTimePerPairIsMeasuredAndCorrected) {
  sim::SessionOptions options;
  options.trajectory.rate_hz = 5.0;  // 100 pairs: the offset's sigma is still under 1 ms
  options.camera_delay_us = 30000;
  RecordingFaults faults;
  faults.one_time_per_pair = true;
  RecordedDrive drive;
  std::string error;
  ASSERT_TRUE(RecordDrive(options, &drive, &error, LidarDetectorConfig{}, nullptr, faults))
      << error;
  sim::SessionSimulator sim;
  ASSERT_TRUE(sim.Init(options, &error)) << error;
  // The camera triggers camera_phase_us into the sweep, and exposes 30 ms after its trigger.
  const double true_offset_s = static_cast<double>(sim.camera_phase_us() + 30000) * 1e-6;

  const RangeImage projection = SessionProjection(MakeLidarModel(LidarKind::kOt128));
  EngineConfig engine;
  const ScoredRun run =
      RunEngine(drive.config, drive.observations, projection, engine, drive.T_camera_lidar);
  ASSERT_TRUE(run.has_estimate) << run.reason << ": " << run.detail;
  EXPECT_EQ(run.verdict, "updated") << run.reason << ": " << run.detail;
  const QualityFigures& q = run.quality;
  ASSERT_TRUE(q.time_offset_fitted);
  EXPECT_NEAR(q.time_offset_s, true_offset_s, 0.002);
  EXPECT_LT(q.time_offset_sigma_s, 0.002);
  EXPECT_NEAR(q.time_offset_corrected_s, true_offset_s, 0.002);
  EXPECT_LT(run.rotation_error_deg, 0.05);
  EXPECT_LT(run.translation_error_m, 0.015);
  std::printf("time offset %.4f s (true %.4f s, sigma %.4f s); error %.3f deg, %.4f m\n",
              q.time_offset_s, true_offset_s, q.time_offset_sigma_s, run.rotation_error_deg,
              run.translation_error_m);

  // Beyond the offset the engine corrects for, the verdict says so, with the offset measured.
  engine.verdict.max_time_offset_s = 0.05;
  const ScoredRun late =
      RunEngine(drive.config, drive.observations, projection, engine, drive.T_camera_lidar);
  EXPECT_EQ(late.verdict, "rejected");
  EXPECT_EQ(late.reason, "time_offset_beyond_tolerance") << late.detail;
  EXPECT_NE(late.detail.find("later than their stamps say"), std::string::npos) << late.detail;
}

}  // namespace
}  // namespace calibd::bench
