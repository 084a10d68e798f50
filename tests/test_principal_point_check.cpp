// The principal point checked from the tags alone (principal_point_check.hpp): tags seen at a
// slant through a camera whose true principal point lies off the configured one, with corner
// noise; the shift is found within its sigma, a correct configuration shows none, and for tags all
// facing the camera the sigma owns up to what the fit cannot tell.

#include "calibd/core/principal_point_check.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calibd/core/geometry.hpp"

namespace calibd {
namespace {

constexpr double kDeg = M_PI / 180.0;

CameraIntrinsics Camera() {
  CameraIntrinsics k;
  k.width = 1920;
  k.height = 1200;
  k.fx = k.fy = 1100.0;
  k.cx = 959.5;
  k.cy = 599.5;
  k.k1 = -0.05;
  k.k2 = 0.01;
  k.p1 = k.p2 = k.k3 = 0.0;
  return k;
}

// `views` tags of 0.7 m at 2-8 m, turned up to `max_turn_deg` about both axes, seen through
// `truth` (its principal point, its distortion), corners with 0.2 px of noise.
SessionObservations Views(const CameraIntrinsics& truth, int views, double max_turn_deg,
                          const BoardGeometry& board) {
  SessionObservations s;
  s.Reserve(views, 1, 4);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 0.2);
  const CameraModel model(truth);
  const auto corners = board.TagCornersInBoard();
  while (s.num_frames < views) {
    SessionObservations::CameraBoard b;
    b.board_index = 0;
    const double z = 2.0 + 3.0 * (1.0 + u(rng));
    b.T_camera_board.linear() = RotationFromRpy(M_PI + max_turn_deg * kDeg * u(rng),
                                                max_turn_deg * kDeg * u(rng), 0.3 * u(rng));
    b.T_camera_board.translation() = Eigen::Vector3d(0.4 * z * u(rng), 0.25 * z * u(rng), z);
    bool seen = true;
    for (int c = 0; c < 4 && seen; ++c) {
      seen = model.Project(b.T_camera_board * corners[c], &b.corners_px[c]);
      b.corners_px[c] += Eigen::Vector2d(noise(rng), noise(rng));
    }
    if (!seen) continue;
    EXPECT_TRUE(s.BeginFrame());
    EXPECT_TRUE(s.AddCameraBoard(b));
  }
  return s;
}

BoardGeometry Board() {
  BoardGeometry g;
  g.width_m = g.height_m = 0.9;
  g.tag_size_m = 0.7;
  return g;
}

TEST(PrincipalPointCheckTest, AShiftedPrincipalPointIsFoundFromSlantedTags) {
  const CameraIntrinsics configured = Camera();
  CameraIntrinsics truth = configured;
  truth.cx += 8.0;
  truth.cy -= 5.0;
  const PrincipalPointEstimate e =
      EstimatePrincipalPoint(configured, {Board()}, Views(truth, 200, 40.0, Board()));
  ASSERT_TRUE(e.fitted);
  EXPECT_EQ(e.observations, 200);
  EXPECT_NEAR(e.shift_px.x(), 8.0, std::max(1.0, 3.0 * e.sigma_px.x()));
  EXPECT_NEAR(e.shift_px.y(), -5.0, std::max(1.0, 3.0 * e.sigma_px.y()));
  EXPECT_LT(e.sigma_px.maxCoeff(), 1.5);
  EXPECT_GT(e.sigma_px.minCoeff(), 0.0);
}

TEST(PrincipalPointCheckTest, ACorrectConfigurationShowsNoShift) {
  const CameraIntrinsics k = Camera();
  const PrincipalPointEstimate e =
      EstimatePrincipalPoint(k, {Board()}, Views(k, 200, 40.0, Board()));
  ASSERT_TRUE(e.fitted);
  EXPECT_LT(std::fabs(e.shift_px.x()), std::max(1.0, 3.0 * e.sigma_px.x()));
  EXPECT_LT(std::fabs(e.shift_px.y()), std::max(1.0, 3.0 * e.sigma_px.y()));
}

TEST(PrincipalPointCheckTest, TagsFacingTheCameraCannotTellAndTooFewAreNotFitted) {
  const CameraIntrinsics configured = Camera();
  CameraIntrinsics truth = configured;
  truth.cx += 8.0;
  // Turned by at most 1 deg: the shift is nearly a sideways move of each tag. Whatever the fit
  // finds, its sigma must own up to it: the truth within 3 sigma.
  const PrincipalPointEstimate flat =
      EstimatePrincipalPoint(configured, {Board()}, Views(truth, 60, 1.0, Board()));
  ASSERT_TRUE(flat.fitted);
  EXPECT_LT(std::fabs(flat.shift_px.x() - 8.0), 3.0 * flat.sigma_px.x() + 1.0)
      << flat.shift_px.x() << " +- " << flat.sigma_px.x();
  const PrincipalPointEstimate few =
      EstimatePrincipalPoint(configured, {Board()}, Views(truth, 5, 35.0, Board()));
  EXPECT_FALSE(few.fitted);
  EXPECT_EQ(few.observations, 5);
}

}  // namespace
}  // namespace calibd
