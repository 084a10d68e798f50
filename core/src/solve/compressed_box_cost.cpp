#include "calibd/core/solve/compressed_box_cost.hpp"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <cmath>
#include <utility>

#include "solve/box_hinge.hpp"

namespace calibd {

namespace {

// Eigenvalues below this fraction of the largest are treated as 0 (directions the terms do not
// constrain, e.g. in-plane translation for one board seen without edges).
constexpr double kRankTolerance = 1e-14;

void RotationAndTranslation(const double* x, Eigen::Matrix3d* R, Eigen::Vector3d* t) {
  *R = Eigen::Quaterniond(x[6], x[3], x[4], x[5]).normalized().toRotationMatrix();
  *t = Eigen::Vector3d(x[0], x[1], x[2]);
}

// Calls f(p, r, J) for every used point of `terms` at (R, t): p the point (LiDAR frame), r its
// robust residual, J its derivative (left untouched unless `jacobian`).
template <typename F>
void ForEachPoint(const std::vector<BoxTerm>& terms, const Eigen::Matrix3d& R,
                  const Eigen::Vector3d& t, double huber, bool jacobian, F&& f) {
  Eigen::Matrix<double, 3, 6> J = Eigen::Matrix<double, 3, 6>::Zero();
  for (const BoxTerm& term : terms) {
    const Eigen::Matrix3d R_bc = term.T_board_camera.linear();
    const Eigen::Vector3d t_bc = term.T_board_camera.translation();
    const int n = term.num_used();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = term.points[i * term.stride].cast<double>();
      Eigen::Vector3d r;
      detail::FixedBoardPointResidual(R, t, R_bc, t_bc, p, term.half_extent, huber, &r,
                                      jacobian ? &J : nullptr);
      f(term, p, r, J);
    }
  }
}

}  // namespace

CompressedBoxCost::CompressedBoxCost(std::vector<BoxTerm> terms, double huber_m)
    : terms_(std::move(terms)), huber_(huber_m) {
  for (const BoxTerm& term : terms_) num_used_ += term.num_used();
  set_num_residuals(kResiduals);
  mutable_parameter_block_sizes()->push_back(7);  // T_camera_lidar
}

void CompressedBoxCost::NormalEquations(const double* x, Eigen::Matrix<double, 6, 6>* H,
                                        Eigen::Matrix<double, 6, 1>* g, double* rtr) const {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  RotationAndTranslation(x, &R, &t);
  H->setZero();
  g->setZero();
  *rtr = 0.0;
  ForEachPoint(terms_, R, t, huber_, true,
               [&](const BoxTerm&, const Eigen::Vector3d&, const Eigen::Vector3d& r,
                   const Eigen::Matrix<double, 3, 6>& J) {
                 *rtr += r.squaredNorm();
                 // Rows of axes inside the box are zero (box_hinge.hpp): skip them.
                 for (int k = 0; k < 3; ++k) {
                   if (r[k] == 0.0) continue;
                   H->noalias() += J.row(k).transpose() * J.row(k);
                   g->noalias() += J.row(k).transpose() * r[k];
                 }
               });
}

bool CompressedBoxCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const double* x = parameters[0];
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> e(residuals);
  e.setZero();
  if (jacobians == nullptr || jacobians[0] == nullptr) {
    Eigen::Matrix3d R;
    Eigen::Vector3d t;
    RotationAndTranslation(x, &R, &t);
    double rtr = 0.0;
    ForEachPoint(terms_, R, t, huber_, false,
                 [&](const BoxTerm&, const Eigen::Vector3d&, const Eigen::Vector3d& r,
                     const Eigen::Matrix<double, 3, 6>&) { rtr += r.squaredNorm(); });
    e[0] = std::sqrt(rtr);
    return true;
  }
  Eigen::Matrix<double, 6, 6> H;
  Eigen::Matrix<double, 6, 1> g;
  double rtr = 0.0;
  NormalEquations(x, &H, &g, &rtr);
  Eigen::Map<Eigen::Matrix<double, kResiduals, 7, Eigen::RowMajor>> J(jacobians[0]);
  J.setZero();
  const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> es(H);
  const double floor = kRankTolerance * std::max(0.0, es.eigenvalues()(5));
  double explained = 0.0;  // |e|^2 so far
  for (int i = 0; i < 6; ++i) {
    const double l = es.eigenvalues()(i);
    if (!(l > floor)) continue;
    const double root = std::sqrt(l);
    J.row(i).head<6>() = root * es.eigenvectors().col(i).transpose();
    e[i] = es.eigenvectors().col(i).dot(g) / root;
    explained += e[i] * e[i];
  }
  e[6] = std::sqrt(std::max(0.0, rtr - explained));
  return true;
}

void CompressedBoxCost::Statistics(const Pose& T_camera_lidar, BoxStatistics* stats) const {
  const Eigen::Matrix3d R = T_camera_lidar.linear();
  const Eigen::Vector3d t = T_camera_lidar.translation();
  const size_t first = stats->term_scores.size();
  stats->term_scores.resize(first + terms_.size(), Eigen::Matrix<double, 6, 1>::Zero());
  ForEachPoint(terms_, R, t, huber_, true,
               [&](const BoxTerm& term, const Eigen::Vector3d& p, const Eigen::Vector3d& r,
                   const Eigen::Matrix<double, 3, 6>& J) {
                 stats->information.noalias() += J.transpose() * J;
                 stats->term_scores[first + static_cast<size_t>(&term - terms_.data())].noalias() +=
                     J.transpose() * r;
                 stats->plane_information.noalias() += J.row(2).transpose() * J.row(2);
                 const Eigen::Vector3d p_board =
                     term.T_board_camera.linear() * (R * p + t) + term.T_board_camera.translation();
                 stats->sum_squared_residuals +=
                     detail::HingeResidual(p_board, term.half_extent).squaredNorm();
                 ++stats->points;
               });
}

}  // namespace calibd
