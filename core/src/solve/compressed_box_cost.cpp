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

// Calls f(term, p, r, J) for every used point of `terms` at (R, t): p the point (LiDAR frame), r
// its robust residual, J its derivative.
template <typename F>
void ForEachPoint(const std::vector<BoxTerm>& terms, const Eigen::Matrix3d& R,
                  const Eigen::Vector3d& t, double huber, F&& f) {
  Eigen::Matrix<double, 3, 6> J;
  for (const BoxTerm& term : terms) {
    const Eigen::Matrix3d R_bc = term.T_board_camera.linear();
    const Eigen::Vector3d t_bc = term.T_board_camera.translation();
    const int n = term.num_used();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = term.points[i * term.stride].cast<double>();
      Eigen::Vector3d r;
      detail::FixedBoardPointResidual(R, t, R_bc, t_bc, p, term.half_extent, huber, &r, &J);
      f(term, p, r, J);
    }
  }
}

// One board axis' share of H and g over the points where that axis is active and within Huber's
// threshold (most points: the plane's axis). There the robust residual is the hinge's r_k and
// the row of J is [a^T, (R w)^T] with a = row k of R_bc and w = p x m, m = row k of R_bc R (the
// rotation's part -a^T [R p]x = ((R p) x a)^T = (R (p x R^T a))^T): the sums over the points
// of 1, w, w w^T, r_k and r_k w, taken in the LiDAR frame, give H and g with R applied once per
// board instead of once per point.
struct AxisSums {
  double count = 0.0, r = 0.0;
  Eigen::Vector3d w = Eigen::Vector3d::Zero(), rw = Eigen::Vector3d::Zero();
  Eigen::Matrix3d ww = Eigen::Matrix3d::Zero();

  void Add(const Eigen::Vector3d& w_point, double r_point) {
    count += 1.0;
    r += r_point;
    w += w_point;
    rw += r_point * w_point;
    ww.noalias() += w_point * w_point.transpose();
  }

  void AddTo(const Eigen::Vector3d& a, const Eigen::Matrix3d& R, Eigen::Matrix<double, 6, 6>* H,
             Eigen::Matrix<double, 6, 1>* g) const {
    if (count == 0.0) return;
    const Eigen::Vector3d Rw = R * w;
    H->topLeftCorner<3, 3>().noalias() += count * a * a.transpose();
    const Eigen::Matrix3d cross = a * Rw.transpose();
    H->topRightCorner<3, 3>() += cross;
    H->bottomLeftCorner<3, 3>() += cross.transpose();
    H->bottomRightCorner<3, 3>().noalias() += R * ww * R.transpose();
    g->head<3>() += r * a;
    g->tail<3>().noalias() += R * rw;
  }
};

}  // namespace

CompressedBoxCost::CompressedBoxCost(std::vector<BoxTerm> terms, double huber_m)
    : terms_(std::move(terms)), huber_(huber_m) {
  for (const BoxTerm& term : terms_) num_used_ += term.num_used();
  set_num_residuals(kResiduals);
  mutable_parameter_block_sizes()->push_back(7);  // T_camera_lidar
}

double CompressedBoxCost::Cost(const double* x) const {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  RotationAndTranslation(x, &R, &t);
  double rtr = 0.0;
  for (const BoxTerm& term : terms_) {
    const Eigen::Matrix3d M = term.T_board_camera.linear() * R;  // LiDAR to board
    const Eigen::Vector3d c = term.T_board_camera.linear() * t + term.T_board_camera.translation();
    const int n = term.num_used();
    for (int i = 0; i < n; ++i) {
      const double rr = detail::HingeResidual(M * term.points[i * term.stride].cast<double>() + c,
                                              term.half_extent)
                            .squaredNorm();
      rtr += detail::HuberRho(rr, huber_);
    }
  }
  return rtr;
}

void CompressedBoxCost::NormalEquations(const double* x, Eigen::Matrix<double, 6, 6>* H,
                                        Eigen::Matrix<double, 6, 1>* g, double* rtr) const {
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
  RotationAndTranslation(x, &R, &t);
  H->setZero();
  g->setZero();
  *rtr = 0.0;
  Eigen::Matrix<double, 3, 6> J;
  for (const BoxTerm& term : terms_) {
    const Eigen::Matrix3d R_bc = term.T_board_camera.linear();
    const Eigen::Vector3d t_bc = term.T_board_camera.translation();
    const Eigen::Matrix3d M = R_bc * R;  // LiDAR to board
    const Eigen::Vector3d c = R_bc * t + t_bc;
    AxisSums sums[3];
    const int n = term.num_used();
    for (int i = 0; i < n; ++i) {
      const Eigen::Vector3d p = term.points[i * term.stride].cast<double>();
      const Eigen::Vector3d r = detail::HingeResidual(M * p + c, term.half_extent);
      const double rr = r.squaredNorm();
      if (rr == 0.0) continue;
      if (detail::BeyondHuber(rr, huber_)) {
        // Beyond Huber's threshold the rows mix the axes (box_hinge.hpp): point by point.
        Eigen::Vector3d robust;
        detail::FixedBoardPointResidual(R, t, R_bc, t_bc, p, term.half_extent, huber_, &robust, &J);
        *rtr += robust.squaredNorm();
        for (int k = 0; k < 3; ++k) {
          if (robust[k] == 0.0) continue;
          H->noalias() += J.row(k).transpose() * J.row(k);
          g->noalias() += J.row(k).transpose() * robust[k];
        }
        continue;
      }
      *rtr += rr;
      for (int k = 0; k < 3; ++k)
        if (r[k] != 0.0) sums[k].Add(p.cross(M.row(k).transpose()), r[k]);
    }
    for (int k = 0; k < 3; ++k) sums[k].AddTo(R_bc.row(k).transpose(), R, H, g);
  }
}

bool CompressedBoxCost::Evaluate(double const* const* parameters, double* residuals,
                                 double** jacobians) const {
  const double* x = parameters[0];
  Eigen::Map<Eigen::Matrix<double, kResiduals, 1>> e(residuals);
  e.setZero();
  if (jacobians == nullptr || jacobians[0] == nullptr) {
    e[0] = std::sqrt(Cost(x));
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
  ForEachPoint(terms_, R, t, huber_,
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
