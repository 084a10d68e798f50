// M2DP (He et al. 2016) with PCA alignment (paper §III-C-2): the power iteration against Eigen's
// SVD, invariance under rigid motions, and the Perron-Frobenius sign rule.

#include "calibd/core/lidar/m2dp.hpp"

#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <Eigen/SVD>
#include <random>
#include <vector>

#include "calibd/core/lidar/cluster_pca.hpp"

namespace calibd {
namespace {

TEST(M2dpTest, PowerIterationMatchesJacobiSvdFirstSingularPair) {
  std::mt19937 rng(3);
  std::uniform_real_distribution<float> u01(0.0f, 1.0f);
  for (int trial = 0; trial < 20; ++trial) {
    const int rows = 8 + trial % 5 * 14, cols = 16 + trial % 3 * 56;
    Eigen::MatrixXf A(rows, cols);
    for (int i = 0; i < rows; ++i)
      for (int j = 0; j < cols; ++j) A(i, j) = std::floor(10.0f * u01(rng));  // counts
    Eigen::VectorXf u(rows), v(cols), scratch(cols);
    float sigma = 0.0f;
    ASSERT_GT(FirstSingularPair(A, 1000, 1e-7, &u, &v, &sigma, &scratch), 0);
    const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A.cast<double>(),
                                                Eigen::ComputeThinU | Eigen::ComputeThinV);
    EXPECT_NEAR(sigma, svd.singularValues()(0), 1e-4 * svd.singularValues()(0));
    EXPECT_NEAR(std::fabs(u.cast<double>().dot(svd.matrixU().col(0))), 1.0, 1e-5);
    EXPECT_NEAR(std::fabs(v.cast<double>().dot(svd.matrixV().col(0))), 1.0, 1e-5);
    // Sign rule: non-negative A gives non-negative first singular vectors (Perron-Frobenius).
    EXPECT_GE(u.sum(), 0.0f);
    EXPECT_GE(u.minCoeff(), -1e-6f);
    EXPECT_GE(v.minCoeff(), -1e-6f);
  }
  Eigen::MatrixXf zero = Eigen::MatrixXf::Zero(4, 6);
  Eigen::VectorXf u(4), v(6), scratch(6);
  float sigma = 1.0f;
  EXPECT_EQ(FirstSingularPair(zero, 100, 1e-6, &u, &v, &sigma, &scratch), -1);
  EXPECT_EQ(sigma, 0.0f);
}

// An asymmetric cluster: a noisy 0.6 m square with a stub below one corner and a short lip.
std::vector<Eigen::Vector3f> AsymmetricCluster(std::mt19937* rng) {
  std::normal_distribution<float> noise(0.0f, 0.01f);
  std::vector<Eigen::Vector3f> p;
  for (int i = 0; i < 20; ++i)
    for (int j = 0; j < 20; ++j)
      p.emplace_back(static_cast<float>(-0.3 + 0.03 * i), static_cast<float>(-0.3 + 0.03 * j),
                     noise(*rng));
  for (int k = 0; k < 30; ++k)
    p.emplace_back(0.25f, static_cast<float>(-0.31 - 0.02 * k), noise(*rng));
  for (int k = 0; k < 15; ++k)
    p.emplace_back(-0.3f, static_cast<float>(0.1 + 0.01 * k), static_cast<float>(0.02 * k));
  return p;
}

std::vector<float> Describe(M2dp* m2dp, const std::vector<Eigen::Vector3f>& points) {
  ClusterPca pca;
  ComputeClusterPca(points.data(), static_cast<int>(points.size()), &pca);
  std::vector<Eigen::Vector3f> aligned(points.size());
  AlignToPrincipalAxes(pca, points.data(), static_cast<int>(points.size()), aligned.data());
  std::vector<float> d(m2dp->size());
  EXPECT_TRUE(m2dp->Compute(aligned.data(), static_cast<int>(aligned.size()), d.data()));
  return d;
}

TEST(M2dpTest, DescriptorIsInvariantUnderRigidMotionsThanksToPcaAlignment) {
  std::mt19937 rng(11);
  const std::vector<Eigen::Vector3f> cluster = AsymmetricCluster(&rng);
  M2dp m2dp;
  ASSERT_EQ(m2dp.size(), 4 * 16 + 8 * 16);
  const std::vector<float> reference = Describe(&m2dp, cluster);
  std::uniform_real_distribution<float> u(-1.0f, 1.0f);
  for (int trial = 0; trial < 20; ++trial) {
    const Eigen::Quaternionf q = Eigen::Quaternionf::UnitRandom();
    const Eigen::Vector3f t(20.0f * u(rng), 20.0f * u(rng), 3.0f * u(rng));
    std::vector<Eigen::Vector3f> moved;
    for (const Eigen::Vector3f& p : cluster) moved.push_back(q * p + t);
    const std::vector<float> d = Describe(&m2dp, moved);
    EXPECT_GE(PearsonCorrelation(reference.data(), d.data(), m2dp.size()), 0.99) << trial;
  }
}

TEST(M2dpTest, PcaAxesAreARightHandedRotationSortedByVariance) {
  std::mt19937 rng(5);
  const std::vector<Eigen::Vector3f> cluster = AsymmetricCluster(&rng);
  ClusterPca pca;
  ComputeClusterPca(cluster.data(), static_cast<int>(cluster.size()), &pca);
  EXPECT_NEAR(pca.axes.determinant(), 1.0, 1e-9);
  EXPECT_TRUE((pca.axes.transpose() * pca.axes).isIdentity(1e-9));
  EXPECT_GE(pca.eigenvalues(0), pca.eigenvalues(1));
  EXPECT_GE(pca.eigenvalues(1), pca.eigenvalues(2));
  EXPECT_NEAR(std::fabs(pca.axes(2, 2)), 1.0, 0.05);  // the square's normal is z
  EXPECT_LT(pca.planarity(), 0.25);                   // the lip leaves the plane
}

TEST(M2dpTest, InPlaneRectangleIsTheBoardWhateverItsTurnInItsPlane) {
  // A 0.6 x 0.4 grid turned 30 deg in its plane and stood upright 10 m ahead: the PCA extents of
  // a square follow any direction, the smallest rectangle its sides.
  for (double w : {0.6, 0.4}) {
    std::vector<Eigen::Vector3f> points;
    const double turn = 30.0 * M_PI / 180.0;
    for (double u = -0.3; u <= 0.3 + 1e-9; u += 0.02)
      for (double v = -w / 2; v <= w / 2 + 1e-9; v += 0.02)
        points.emplace_back(10.0f, static_cast<float>(std::cos(turn) * u - std::sin(turn) * v),
                            static_cast<float>(std::sin(turn) * u + std::cos(turn) * v));
    ClusterPca pca;
    ComputeClusterPca(points.data(), static_cast<int>(points.size()), &pca);
    const Eigen::Vector2d rect =
        InPlaneRectangle(pca, points.data(), static_cast<int>(points.size()));
    EXPECT_NEAR(rect(0), 0.6, 0.01) << w;
    EXPECT_NEAR(rect(1), w, 0.01) << w;
  }
}

TEST(M2dpTest, TheMostPointsWindowIsTheBoardBesideAStripAlongItsEdgeAndBelowIt) {
  // A 0.8 x 0.6 grid turned 25 deg in its plane 6 m ahead, with an 8 cm wide strip of another
  // surface along its short edge and running on 0.2 m below it (a body crossing the board's plane,
  // 12 % of the points): the 0.8 x 0.6 window holds the board and none of the strip, and
  // Contains says which points.
  const double turn = 25.0 * M_PI / 180.0;
  auto at = [&](double u, double v) {
    return Eigen::Vector3f(6.0f, static_cast<float>(std::cos(turn) * u - std::sin(turn) * v),
                           static_cast<float>(std::sin(turn) * u + std::cos(turn) * v));
  };
  std::vector<Eigen::Vector3f> points;
  int board = 0;
  for (double u = -0.4 + 0.01; u < 0.4; u += 0.02)
    for (double v = -0.3 + 0.01; v < 0.3; v += 0.02, ++board) points.push_back(at(u, v));
  for (double u = -0.4 - 0.015; u > -0.49; u -= 0.02)
    for (double v = -0.5 + 0.01; v < 0.3; v += 0.02) points.push_back(at(u, v));
  const int n = static_cast<int>(points.size());
  ASSERT_LT(n - board, 0.15 * n);
  ClusterPca pca;
  ComputeClusterPca(points.data(), n, &pca);
  std::vector<std::pair<float, float>> scratch(n);
  const PlaneWindow w = MostPointsWindow(pca, points.data(), n, 0.8, 0.6, scratch.data());
  int inside_board = 0, inside_strip = 0;
  for (int i = 0; i < n; ++i)
    (i < board ? inside_board : inside_strip) += w.Contains(pca, points[i]);
  EXPECT_EQ(w.count, inside_board + inside_strip);
  EXPECT_GE(inside_board, 0.99 * board);  // a corner point or so, for a turn a tenth of a step off
  EXPECT_EQ(inside_strip, 0);
}

TEST(M2dpTest, AWeightCountsLikeThatManyCopiesOfAPoint) {
  std::mt19937 rng(7);
  const std::vector<Eigen::Vector3f> cluster = AsymmetricCluster(&rng);
  std::vector<Eigen::Vector3f> copies = cluster;
  std::vector<float> weights(cluster.size(), 1.0f);
  for (size_t i = 0; i < cluster.size(); i += 3) {  // every third point twice
    copies.push_back(cluster[i]);
    weights[i] = 2.0f;
  }
  const int n = static_cast<int>(cluster.size()), m = static_cast<int>(copies.size());
  ClusterPca weighted, copied;
  ComputeClusterPca(cluster.data(), n, &weighted, weights.data());
  ComputeClusterPca(copies.data(), m, &copied);
  EXPECT_LT((weighted.centroid - copied.centroid).norm(), 1e-9);
  EXPECT_TRUE(weighted.axes.isApprox(copied.axes, 1e-9));
  std::vector<Eigen::Vector3f> a(n), b(m);
  AlignToPrincipalAxes(weighted, cluster.data(), n, a.data());
  AlignToPrincipalAxes(copied, copies.data(), m, b.data());
  M2dp m2dp;
  std::vector<float> da(m2dp.size()), db(m2dp.size());
  ASSERT_TRUE(m2dp.Compute(a.data(), n, da.data(), weights.data()));
  ASSERT_TRUE(m2dp.Compute(b.data(), m, db.data()));
  EXPECT_NEAR(PearsonCorrelation(da.data(), db.data(), m2dp.size()), 1.0, 1e-5);
}

TEST(M2dpTest, PearsonCorrelationOfKnownVectors) {
  const float a[4] = {1, 2, 3, 4}, b[4] = {2, 4, 6, 8}, c[4] = {4, 3, 2, 1}, k[4] = {1, 1, 1, 1};
  EXPECT_NEAR(PearsonCorrelation(a, b, 4), 1.0, 1e-12);
  EXPECT_NEAR(PearsonCorrelation(a, c, 4), -1.0, 1e-12);
  EXPECT_EQ(PearsonCorrelation(a, k, 4), 0.0);
}

}  // namespace
}  // namespace calibd
