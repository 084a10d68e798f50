// The principal point checked from the tags alone (principal_point_check.hpp): tags seen at a
// slant through a camera whose true principal point lies off the configured one, with corner
// noise; the shift is found within its sigma, a correct configuration shows none, and for tags all
// facing the camera the sigma owns up to what the fit cannot tell.

#include "calibd/core/verdict/principal_point_check.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <random>

#include "calibd/core/common/geometry.hpp"

namespace calibd {
namespace {

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

// `views` tags of 0.7 m at 2-8 m (or as far as `min_m` to `min_m` + 6 m), turned up to
// `max_turn_deg` about both axes, seen through `truth` (its principal point, its distortion),
// corners with `noise_px` of noise plus `bias` on corner `biased_corner` (none: -1).
SessionObservations Views(const CameraIntrinsics& truth, int views, double max_turn_deg,
                          const BoardGeometry& board, double noise_px = 0.2, double min_m = 2.0,
                          int biased_corner = -1, const Eigen::Vector2d& bias = {0.0, 0.0}) {
  SessionObservations s;
  s.Reserve(views, 1, 4);
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px);
  const CameraModel model(truth);
  const auto corners = board.TagCornersInBoard();
  while (s.num_frames < views) {
    SessionObservations::CameraBoard b;
    b.board_index = 0;
    const double z = min_m + 3.0 * (1.0 + u(rng));
    b.T_camera_board.linear() = RotationFromRpy(M_PI + max_turn_deg * kDeg2Rad * u(rng),
                                                max_turn_deg * kDeg2Rad * u(rng), 0.3 * u(rng));
    b.T_camera_board.translation() = Eigen::Vector3d(0.4 * z * u(rng), 0.25 * z * u(rng), z);
    bool seen = true;
    for (int c = 0; c < 4 && seen; ++c) {
      seen = model.Project(b.T_camera_board * corners[c], &b.corners_px[c]);
      b.corners_px[c] += Eigen::Vector2d(noise(rng), noise(rng));
      if (c == biased_corner) b.corners_px[c] += bias;
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

// A statement far sharper than the tags' own sigma counts only kMaxStatedSharpening times
// sharper: where the tags can hardly see the principal point (square-on boards), a wrong
// intrinsic calibration would otherwise pass unseen under a bound resting on the statement alone.
TEST(PrincipalPointCheckTest, AStatementIsTakenNoSharperThanTheTagsCouldCheck) {
  PrincipalPointEstimate tags;
  tags.fitted = true;
  tags.shift_px = {2.0, -5.0};
  tags.sigma_px = {4.5, 2.0};  // x: 1.5 px checked, beyond the 1 px stated; y: 0.67 px
  tags.systematic_px = {0.0, 0.0};
  const PrincipalPointBelief b = CombinePrincipalPoint(tags, 1.0, CornerBias::kNone);
  // x: the statement as 4.5 / 3 px, so the tags weigh 1 / (1 + 3^2).
  const double w = 1.0 / (1.0 + kMaxStatedSharpening * kMaxStatedSharpening);
  EXPECT_NEAR(b.shift_px.x(), w * 2.0, 1e-12);
  EXPECT_NEAR(b.sigma_px.x(), std::sqrt(w * 4.5 * 4.5), 1e-12);
  EXPECT_GT(b.sigma_px.x(), 1.0);  // wider than the statement alone
  // y: the statement as it is, 1 px against the tags' 2 px.
  EXPECT_NEAR(b.shift_px.y(), -5.0 / 5.0, 1e-12);
  EXPECT_NEAR(b.sigma_px.y(), std::sqrt(0.8), 1e-12);
}

}  // namespace
}  // namespace calibd

namespace calibd {
namespace {

// A corner bias the same in every view is what no resampling sees: the systematic bound owns up
// to it. Noise-free views, one corner of every tag moved by kCornerBiasPx along x, then along y:
// the shift moves by no more than systematic_px (which sums all eight such biases), and by a
// good part of it for at least one of them. Far, little-slanted tags leave a bound many times
// that of near, slanted ones.
TEST(PrincipalPointCheckTest, ACornerBiasCommonToEveryTagMovesTheShiftWithinTheSystematicBound) {
  const CameraIntrinsics k = Camera();
  const PrincipalPointEstimate clean =
      EstimatePrincipalPoint(k, {Board()}, Views(k, 200, 40.0, Board(), 0.0));
  ASSERT_TRUE(clean.fitted);
  EXPECT_LT(clean.shift_px.norm(), 1e-6);
  double largest_share = 0.0;
  for (int corner = 0; corner < 4; ++corner) {
    for (int axis = 0; axis < 2; ++axis) {
      const Eigen::Vector2d bias = Eigen::Vector2d::Unit(axis) * kCornerBiasPx;
      const PrincipalPointEstimate e = EstimatePrincipalPoint(
          k, {Board()}, Views(k, 200, 40.0, Board(), 0.0, 2.0, corner, bias));
      ASSERT_TRUE(e.fitted);
      for (int a = 0; a < 2; ++a) {
        EXPECT_LE(std::fabs(e.shift_px[a]), e.systematic_px[a] * 1.05)
            << "corner " << corner << " axis " << axis;
        largest_share = std::max(largest_share, std::fabs(e.shift_px[a]) / e.systematic_px[a]);
      }
    }
  }
  EXPECT_GT(largest_share, 0.3);
  const PrincipalPointEstimate far =
      EstimatePrincipalPoint(k, {Board()}, Views(k, 200, 10.0, Board(), 0.0, 15.0));
  ASSERT_TRUE(far.fitted);
  EXPECT_GT(far.systematic_px.minCoeff(), 5.0 * clean.systematic_px.maxCoeff())
      << far.systematic_px.transpose() << " against " << clean.systematic_px.transpose();
  std::printf("systematic bound: near slanted tags %.2f, %.2f px; far, little slanted %.2f, %.2f\n",
              clean.systematic_px.x(), clean.systematic_px.y(), far.systematic_px.x(),
              far.systematic_px.y());
}

// The principal point as the error bound knows it: the tags (their sigma and, with the corners'
// bias assumed, their blind spot in quadrature) weighed against the intrinsic calibration's
// stated sigma, axis by axis.
TEST(PrincipalPointCheckTest, TheTagsAndTheStatedSigmaCombineByTheirVariances) {
  PrincipalPointEstimate tags;
  tags.fitted = true;
  tags.shift_px = {6.0, -2.0};
  tags.sigma_px = {3.0, 1.0};
  tags.systematic_px = {4.0, 0.0};  // x: 5 px in all
  // Nothing stated: the tags alone, blind spot included.
  PrincipalPointBelief b = CombinePrincipalPoint(tags, 0.0, CornerBias::kAssumed);
  EXPECT_DOUBLE_EQ(b.shift_px.x(), 6.0);
  EXPECT_DOUBLE_EQ(b.sigma_px.x(), 5.0);
  EXPECT_DOUBLE_EQ(b.sigma_px.y(), 1.0);
  EXPECT_DOUBLE_EQ(StatedPrincipalPointChiSquare(tags, 0.0, CornerBias::kAssumed), 0.0);
  // 1 px stated: x weighs the tags 1/26, y 1/2.
  b = CombinePrincipalPoint(tags, 1.0, CornerBias::kAssumed);
  EXPECT_NEAR(b.shift_px.x(), 6.0 / 26.0, 1e-12);
  EXPECT_NEAR(b.sigma_px.x(), std::sqrt(25.0 / 26.0), 1e-12);
  EXPECT_NEAR(b.shift_px.y(), -1.0, 1e-12);
  EXPECT_NEAR(b.sigma_px.y(), std::sqrt(0.5), 1e-12);
  // Corners taken as unbiased: x weighs the tags 1/10 (3 px against 1 px), y as before.
  b = CombinePrincipalPoint(tags, 1.0, CornerBias::kNone);
  EXPECT_NEAR(b.shift_px.x(), 6.0 / 10.0, 1e-12);
  EXPECT_NEAR(b.sigma_px.x(), std::sqrt(9.0 / 10.0), 1e-12);
  EXPECT_NEAR(b.shift_px.y(), -1.0, 1e-12);
  EXPECT_NEAR(StatedPrincipalPointChiSquare(tags, 1.0, CornerBias::kAssumed),
              36.0 / 26.0 + 4.0 / 2.0, 1e-12);
  // Tags sharper than their blind spot: read as biased, they do not refute the stated 1 px
  // (chi-square 4); read as unbiased they do (20, beyond 9.21), and that reading takes them alone.
  tags.sigma_px = {1.0, 1.0};
  EXPECT_NEAR(StatedPrincipalPointChiSquare(tags, 1.0, CornerBias::kNone), 20.0, 1e-12);
  b = CombinePrincipalPoint(tags, 1.0, CornerBias::kAssumed);
  EXPECT_NEAR(b.shift_px.x(), 6.0 / 18.0, 1e-12);
  b = CombinePrincipalPoint(tags, 1.0, CornerBias::kNone);
  EXPECT_EQ(b.shift_px, tags.shift_px);
  EXPECT_EQ(b.sigma_px, tags.sigma_px);
  // Tags that could not fit: the stated sigma alone, or nothing known.
  tags.fitted = false;
  b = CombinePrincipalPoint(tags, 1.5, CornerBias::kNone);
  EXPECT_EQ(b.shift_px, Eigen::Vector2d::Zero());
  EXPECT_DOUBLE_EQ(b.sigma_px.y(), 1.5);
  EXPECT_TRUE(std::isinf(CombinePrincipalPoint(tags, 0.0, CornerBias::kAssumed).sigma_px.x()));
}

}  // namespace
}  // namespace calibd
