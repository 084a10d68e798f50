#include "calibd/core/lidar/m2dp.hpp"

#include <Eigen/Geometry>

#include <algorithm>
#include <cmath>

#include "calibd/core/lidar/range_image.hpp"

namespace calibd {

int FirstSingularPair(const Eigen::MatrixXf& A, int max_iterations, double tolerance,
                      Eigen::VectorXf* u, Eigen::VectorXf* v, float* sigma,
                      Eigen::VectorXf* scratch) {
  // Power iteration v <- A^T A v / |A^T A v| (Golub & Van Loan §8.2.1), applied as two
  // matrix-vector products so that A^T A is never formed. The all-ones start is not orthogonal to
  // the non-negative Perron vector of a non-negative A.
  v->setConstant(1.0f / std::sqrt(static_cast<float>(A.cols())));
  int it = 0;
  for (; it < max_iterations; ++it) {
    u->noalias() = A * (*v);
    scratch->noalias() = A.transpose() * (*u);
    const float norm = scratch->norm();
    if (!(norm > 0.0f)) {
      u->setZero();
      v->setZero();
      *sigma = 0.0f;
      return -1;
    }
    *scratch /= norm;
    const float change = (*scratch - *v).norm();
    v->swap(*scratch);
    if (change < tolerance) {
      ++it;
      break;
    }
  }
  u->noalias() = A * (*v);
  *sigma = u->norm();
  if (*sigma > 0.0f) *u /= *sigma;
  if (u->sum() < 0.0f) {
    *u = -*u;
    *v = -*v;
  }
  return it;
}

double PearsonCorrelation(const float* a, const float* b, int n) {
  if (n <= 0) return 0.0;
  double ma = 0.0, mb = 0.0;
  for (int i = 0; i < n; ++i) {
    ma += a[i];
    mb += b[i];
  }
  ma /= n;
  mb /= n;
  double sab = 0.0, saa = 0.0, sbb = 0.0;
  for (int i = 0; i < n; ++i) {
    const double da = a[i] - ma, db = b[i] - mb;
    sab += da * db;
    saa += da * da;
    sbb += db * db;
  }
  if (saa <= 0.0 || sbb <= 0.0) return 0.0;
  return sab / std::sqrt(saa * sbb);
}

M2dp::M2dp(const M2dpConfig& config) : config_(config) {
  const int p = std::max(1, config.elevations), q = std::max(1, config.azimuths);
  rows_ = p * q;
  cols_ = std::max(1, config.rings) * std::max(1, config.sectors);
  basis_x_.resize(rows_, 3);
  basis_y_.resize(rows_, 3);
  for (int i = 0; i < p; ++i) {
    const double phi = i * (M_PI / 2.0) / p;
    for (int j = 0; j < q; ++j) {
      const double theta = j * M_PI / q;
      const Eigen::Vector3d m(std::cos(phi) * std::cos(theta), std::cos(phi) * std::sin(theta),
                              std::sin(phi));
      // In-plane x axis: the cluster's x axis projected onto the plane (He §III-B); its y axis
      // when the normal is the x axis itself.
      Eigen::Vector3d x = Eigen::Vector3d::UnitX() - m.x() * m;
      if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitY() - m.y() * m;
      x.normalize();
      const Eigen::Vector3d y = m.cross(x);
      basis_x_.row(i * q + j) = x.cast<float>().transpose();
      basis_y_.row(i * q + j) = y.cast<float>().transpose();
    }
  }
  A_.setZero(rows_, cols_);
  u_.setZero(rows_);
  v_.setZero(cols_);
  scratch_.setZero(cols_);
}

bool M2dp::Compute(const Eigen::Vector3f* aligned, int n, float* descriptor, const float* weights) {
  A_.setZero();
  std::fill(descriptor, descriptor + size(), 0.0f);
  float r2_max = 0.0f;
  for (int k = 0; k < n; ++k) r2_max = std::max(r2_max, aligned[k].squaredNorm());
  if (n < 2 || !(r2_max > 0.0f)) return false;
  const int l = std::max(1, config_.rings), t = std::max(1, config_.sectors);
  const float inv_r2_max = 1.0f / r2_max;
  const float sector_scale = static_cast<float>(t / (2.0 * M_PI));
  for (int plane = 0; plane < rows_; ++plane) {
    const Eigen::Vector3f bx = basis_x_.row(plane).transpose();
    const Eigen::Vector3f by = basis_y_.row(plane).transpose();
    for (int k = 0; k < n; ++k) {
      const float px = bx.dot(aligned[k]), py = by.dot(aligned[k]);
      // Ring k holds r / r_max in ((k/l)^2, ((k+1)/l)^2]: k = floor(l sqrt(r / r_max)).
      const float rel = std::sqrt(std::sqrt((px * px + py * py) * inv_r2_max));
      const int ring = std::min(l - 1, static_cast<int>(rel * static_cast<float>(l)));
      int sector = static_cast<int>((FastAtan2(py, px) + static_cast<float>(M_PI)) * sector_scale);
      sector = std::min(t - 1, std::max(0, sector));
      A_(plane, ring * t + sector) += weights ? weights[k] : 1.0f;
    }
  }
  float sigma = 0.0f;
  if (FirstSingularPair(A_, config_.max_iterations, config_.tolerance, &u_, &v_, &sigma,
                        &scratch_) < 0)
    return false;
  std::copy(u_.data(), u_.data() + rows_, descriptor);
  std::copy(v_.data(), v_.data() + cols_, descriptor + rows_);
  return true;
}

}  // namespace calibd
