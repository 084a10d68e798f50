// The cluster-robust covariance against Monte Carlo: a linear least-squares problem whose errors
// are shared by stretches of frames (as a drive's motion and timing errors are). The formal
// covariance, which takes every row as independent, understates the scatter of the estimate;
// the clustered one matches it.

#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include "calibd/core/solve/clustered_covariance.hpp"
#include "calibd/core/verdict/measure_quality.hpp"

namespace calibd {
namespace {

using Matrix6d = Eigen::Matrix<double, 6, 6>;
using Vector6d = Eigen::Matrix<double, 6, 1>;

constexpr int kFrames = 80, kRowsPerObservation = 10, kStretches = 8, kDraws = 3000;
constexpr double kSharedSigma = 0.5, kOwnSigma = 0.3;

TEST(ClusteredCovarianceTest, MatchesTheScatterOfAnEstimateWhoseErrorsStretchesShare) {
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  // One observation a frame, its rows' design fixed over the draws: alike within a frame (a
  // board's points constrain the extrinsic in about the same direction), so that an error they
  // share adds up where independent ones would cancel.
  std::vector<Eigen::Matrix<double, kRowsPerObservation, 6>> A(kFrames);
  Matrix6d H = Matrix6d::Zero();
  for (auto& a : A) {
    Vector6d direction;
    for (int j = 0; j < 6; ++j) direction(j) = n(rng);
    for (int i = 0; i < a.rows(); ++i)
      for (int j = 0; j < 6; ++j) a(i, j) = direction(j) + 0.3 * n(rng);
    H += a.transpose() * a;
  }
  const Matrix6d H_inv = H.inverse();
  Matrix6d scatter = Matrix6d::Zero(), clustered = Matrix6d::Zero(), formal = Matrix6d::Zero();
  for (int draw = 0; draw < kDraws; ++draw) {
    // Each stretch of 10 frames shares one error in every row, beside the rows' own.
    std::vector<double> shared(kStretches);
    for (double& s : shared) s = kSharedSigma * n(rng);
    std::vector<Eigen::Matrix<double, kRowsPerObservation, 1>> y(kFrames);
    Vector6d g = Vector6d::Zero();
    for (int f = 0; f < kFrames; ++f) {
      for (int i = 0; i < kRowsPerObservation; ++i)
        y[f](i) = shared[f * kStretches / kFrames] + kOwnSigma * n(rng);
      g += A[f].transpose() * y[f];
    }
    const Vector6d estimate = H_inv * g;  // the truth is 0
    scatter += estimate * estimate.transpose();
    // Scores of the residuals at the estimate, as the solve has them.
    std::vector<ObservationScore> scores(kFrames);
    double rss = 0.0;
    for (int f = 0; f < kFrames; ++f) {
      const Eigen::Matrix<double, kRowsPerObservation, 1> r = y[f] - A[f] * estimate;
      scores[f].board = 0;
      scores[f].frame = f;
      scores[f].score = A[f].transpose() * r;
      rss += r.squaredNorm();
    }
    const ClusteredCovariance c = ClusterRobustCovariance(H, scores, kStretches);
    ASSERT_TRUE(c.valid);
    EXPECT_EQ(c.stretches, kStretches);
    EXPECT_EQ(c.boards, 1);
    clustered += c.covariance;
    formal += H_inv * rss / (kFrames * kRowsPerObservation - 6);
  }
  for (int j = 0; j < 6; ++j) {
    const double truth = scatter(j, j) / kDraws;
    const double mean_clustered = clustered(j, j) / kDraws, mean_formal = formal(j, j) / kDraws;
    std::printf("parameter %d: scatter %.3e, clustered %.3e (%.2f), formal %.3e (%.2f)\n", j, truth,
                mean_clustered, mean_clustered / truth, mean_formal, mean_formal / truth);
    EXPECT_GT(mean_clustered / truth, 0.6) << j;
    EXPECT_LT(mean_clustered / truth, 1.5) << j;
    EXPECT_LT(mean_formal / truth, 0.5) << j;
  }
}

TEST(ClusteredCovarianceTest, NeedsTwoStretchesAndAnInvertibleInformation) {
  std::vector<ObservationScore> one_frame(3);
  for (int k = 0; k < 3; ++k) one_frame[k].frame = 4, one_frame[k].board = k;
  EXPECT_FALSE(ClusterRobustCovariance(Matrix6d::Identity(), one_frame, 8).valid);
  std::vector<ObservationScore> two(2);
  two[1].frame = 1;
  EXPECT_FALSE(ClusterRobustCovariance(Matrix6d::Zero(), two, 8).valid);
  const ClusteredCovariance c = ClusterRobustCovariance(Matrix6d::Identity(), two, 8);
  EXPECT_TRUE(c.valid);
  EXPECT_EQ(c.stretches, 2);
}

// The error bound's quantile of a 3-D Gaussian error's norm: chi-square's for one, two and three
// equal directions, and Monte Carlo's for an unequal covariance.
TEST(ClusteredCovarianceTest, TheNormQuantileOfAGaussianErrorMatchesItsDistribution) {
  const auto quantile = [](const Eigen::Vector3d& variances) {
    return GaussianNormQuantile99(variances.asDiagonal().toDenseMatrix());
  };
  EXPECT_NEAR(quantile({4.0, 0.0, 0.0}), 2.0 * 2.5758, 0.01);  // sqrt chi2(1, 0.99)
  EXPECT_NEAR(quantile({4.0, 4.0, 0.0}), 2.0 * 3.0349, 0.01);  // sqrt chi2(2, 0.99)
  EXPECT_NEAR(quantile({4.0, 4.0, 4.0}), 2.0 * kBoundNormQuantile3d, 0.01);
  EXPECT_EQ(quantile({0.0, 0.0, 0.0}), 0.0);
  EXPECT_TRUE(std::isinf(quantile({1.0, std::numeric_limits<double>::infinity(), 1.0})));
  // A turned, unequal covariance against 200000 draws.
  const Eigen::Matrix3d R =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1.0, 2.0, 3.0).normalized()).toRotationMatrix();
  const Eigen::Matrix3d cov = R * Eigen::Vector3d(9.0, 2.0, 0.25).asDiagonal() * R.transpose();
  const Eigen::Matrix3d L = cov.llt().matrixL();
  std::mt19937 rng(7);
  std::normal_distribution<double> z;
  std::vector<double> norms(200000);
  for (double& n : norms) n = (L * Eigen::Vector3d(z(rng), z(rng), z(rng))).norm();
  std::nth_element(norms.begin(), norms.begin() + 198000, norms.end());
  EXPECT_NEAR(GaussianNormQuantile99(cov), norms[198000], 0.01 * norms[198000]);
}

// The bound's principal point term holds whichever reading of the tags' corners is true: it takes
// the reading whose bound is the larger. Weak tags (a blind spot of 7 px) that read a 5 px shift
// leave the biased reading at about the stated 1 px; read as unbiased (2 px against 1 px), they
// pull the belief a fifth of the way, and that turn is added as a bias.
TEST(ClusteredCovarianceTest, TheErrorBoundTakesTheLargerReadingOfTheTagsCorners) {
  DirectResult direct;
  direct.clustered.valid = true;
  direct.clustered.stretches = 8;
  direct.clustered.covariance.setIdentity();
  direct.clustered.covariance *= 1e-8;  // 0.1 mrad, 0.1 mm: the principal point dominates
  constexpr double kF = 1200.0;
  // A belief of a shift along u, as the bound without a measured response takes it: the turn.
  const auto turn = [](double turn_deg, double sigma_px) {
    QualityFigures::PrincipalPointTurn t;
    t.turn_deg = turn_deg;
    t.sigma_rad = Eigen::Vector2d::Constant(sigma_px / kF);
    t.shift_px = {turn_deg / kRad2Deg * kF, 0.0};
    t.sigma_px = Eigen::Vector2d::Constant(sigma_px);
    return t;
  };
  QualityFigures q;
  q.principal_point_beliefs[static_cast<size_t>(CornerBias::kAssumed)] =
      turn(5.0 / 50.0 / kF * kRad2Deg, std::sqrt(49.0 / 50.0));
  q.principal_point_beliefs[static_cast<size_t>(CornerBias::kNone)] =
      turn(5.0 / 5.0 / kF * kRad2Deg, std::sqrt(4.0 / 5.0));
  ErrorBound(direct, &q);
  EXPECT_EQ(q.principal_point_bound_corners, CornerBias::kNone);
  const auto bound_of = [&](const QualityFigures::PrincipalPointTurn& t) {
    const Eigen::Matrix3d cov =
        direct.clustered.covariance.bottomRightCorner<3, 3>() *
            FewClustersVarianceFactor(direct.clustered.stretches) +
        Eigen::Vector3d(t.sigma_rad.y() * t.sigma_rad.y(), t.sigma_rad.x() * t.sigma_rad.x(), 0.0)
            .asDiagonal()
            .toDenseMatrix();
    return t.turn_deg + GaussianNormQuantile99(cov) * kRad2Deg;
  };
  const double biased = bound_of(q.principal_point_beliefs[0]);
  const double unbiased = bound_of(q.principal_point_beliefs[1]);
  EXPECT_GT(unbiased, biased);
  EXPECT_NEAR(q.rotation_bound_deg, unbiased, 1e-12);
  EXPECT_EQ(q.principal_point_belief.turn_deg, q.principal_point_beliefs[1].turn_deg);
  // Tags that agree with the stated sigma: the biased reading, wider, is the bound.
  q.principal_point_beliefs[1] = turn(0.0, 0.5);
  ErrorBound(direct, &q);
  EXPECT_EQ(q.principal_point_bound_corners, CornerBias::kAssumed);
  EXPECT_NEAR(q.rotation_bound_deg, biased, 1e-12);
  // With the response measured, the belief is carried through it: a response of a pure turn
  // about the camera's y axis (1 / f rad per px along u) and 4 m of translation along x per rad
  // adds to the translation bound what it adds to the rotation's, times 4 m.
  const double translation_before = q.translation_bound_m;
  q.principal_point_response_measured = true;
  q.principal_point_response.setZero();
  q.principal_point_response(4, 0) = 1.0 / kF;
  q.principal_point_response(3, 1) = 1.0 / kF;
  q.principal_point_response(0, 0) = 4.0 / kF;
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_bound_deg, biased, 1e-9);
  const QualityFigures::PrincipalPointTurn& taken = q.principal_point_beliefs[0];
  EXPECT_NEAR(q.translation_bound_principal_point_m,
              4.0 / kF * (std::fabs(taken.shift_px.x()) + 2.5758 * taken.sigma_px.x()), 1e-4);
  EXPECT_GT(q.translation_bound_m, translation_before);
}

// The bound's statistical part is the clustered covariance, but never narrower than the formal
// one: boards with few points, most inside their box's hinge, can leave the clustered one the
// narrower (CalibrationEngineTest.TheReprojectionGateFollowsTheLidarsPointSpacing).
TEST(ClusteredCovarianceTest, TheBoundsStatisticalPartIsNeverNarrowerThanTheFormalCovariance) {
  DirectResult direct;
  direct.clustered.valid = true;
  direct.clustered.stretches = 8;
  direct.clustered.covariance = Eigen::Matrix<double, 6, 6>::Identity() * 1e-8;  // 0.1 mrad
  direct.residual_rms_m = 0.01;
  const double widened = FewClustersVarianceFactor(direct.clustered.stretches);
  const auto quantile_deg = [](double variance) {
    return GaussianNormQuantile99(Eigen::Matrix3d::Identity() * variance) * kRad2Deg;
  };
  QualityFigures q;
  // Formal 1 mrad (rms^2 / 100): wider, taken.
  direct.information = Eigen::Matrix<double, 6, 6>::Identity() * 100.0;
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_statistical_deg, quantile_deg(1e-6), 1e-12);
  EXPECT_NEAR(q.rotation_clustered_sigma_deg, 1e-3 * kRad2Deg, 1e-9);  // as the bound takes it
  EXPECT_NEAR(q.translation_clustered_sigma_m, 1e-3, 1e-12);
  // Formal 0.01 mrad: narrower, the clustered one stays.
  direct.information = Eigen::Matrix<double, 6, 6>::Identity() * 1e6;
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_statistical_deg, quantile_deg(1e-8 * widened), 1e-12);
  // The formal rotation wider, its translation narrower: each block takes the wider.
  direct.information.diagonal() << 1e6, 1e6, 1e6, 100.0, 100.0, 100.0;
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_clustered_sigma_deg, 1e-3 * kRad2Deg, 1e-9);
  EXPECT_NEAR(q.translation_clustered_sigma_m, std::sqrt(1e-8 * widened), 1e-12);
  // Wider along one direction only: the other directions keep the clustered variance.
  direct.information = Eigen::Matrix<double, 6, 6>::Identity() * 1e6;
  direct.information(3, 3) = 100.0;
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_clustered_sigma_deg, 1e-3 * kRad2Deg, 1e-9);
  EXPECT_NEAR(
      q.rotation_statistical_deg,
      GaussianNormQuantile99(
          Eigen::Vector3d(1e-6, 1e-8 * widened, 1e-8 * widened).asDiagonal().toDenseMatrix()) *
          kRad2Deg,
      1e-9);
  // Singular information (no formal covariance): the clustered one.
  direct.information.setZero();
  ErrorBound(direct, &q);
  EXPECT_NEAR(q.rotation_statistical_deg, quantile_deg(1e-8 * widened), 1e-12);
}

}  // namespace
}  // namespace calibd
