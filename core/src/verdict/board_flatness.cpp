#include "calibd/core/verdict/board_flatness.hpp"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

namespace calibd {

namespace {

/// Points nearer the edges than this share of the half size are left out: a beam that straddles
/// an edge returns a range between the board and what is behind it.
constexpr double kInnerShare = 0.9;
/// An observation enters with at least this many inner points.
constexpr int kMinPoints = 20;
/// Consecutive observations of a board share their errors (the frames of one still pose): the
/// scatter counts blocks of this many.
constexpr int kBlockObservations = 5;

struct ObservationBend {
  int board = -1;
  Eigen::Vector2d c = Eigen::Vector2d::Zero();    ///< c_u, c_v
  Eigen::Vector2d var = Eigen::Vector2d::Zero();  ///< their least-squares variances
};

using Vector5d = Eigen::Matrix<double, 5, 1>;
using Matrix5d = Eigen::Matrix<double, 5, 5>;

/// The five-term fit of the header over one observation's inner points; false when too few or
/// too concentrated to separate a bend from the plane.
bool FitObservation(const BoardGeometry& g, const ObservationSet& set, const BoardObservation& o,
                    const Pose& T_board_lidar, ObservationBend* out) {
  const double hu = g.width_m / 2.0, hv = g.height_m / 2.0;
  Matrix5d ata = Matrix5d::Zero();
  Vector5d atz = Vector5d::Zero();
  double ztz = 0.0;
  int n = 0;
  for (int k = 0; k < o.num_points; ++k) {
    const Eigen::Vector3d p =
        T_board_lidar * set.points[static_cast<size_t>(o.first_point + k)].cast<double>();
    const double u = p.x() / hu, v = p.y() / hv;
    if (std::abs(u) > kInnerShare || std::abs(v) > kInnerShare) continue;
    Vector5d a;
    a << 1.0, u, v, 1.0 - u * u, 1.0 - v * v;
    ata.selfadjointView<Eigen::Lower>().rankUpdate(a);
    atz += a * p.z();
    ztz += p.z() * p.z();
    ++n;
  }
  if (n < kMinPoints) return false;
  ata = ata.selfadjointView<Eigen::Lower>();
  const Eigen::LDLT<Matrix5d> ldlt(ata);
  if (ldlt.info() != Eigen::Success || ldlt.vectorD().minCoeff() <= 1e-9 * ata.trace())
    return false;
  const Vector5d x = ldlt.solve(atz);
  const double rss = std::max(0.0, ztz - 2.0 * x.dot(atz) + x.dot(ata * x));
  const double s2 = rss / std::max(1, n - 5);
  const Matrix5d cov = ldlt.solve(Matrix5d::Identity()) * s2;
  if (!(cov(3, 3) > 0.0 && cov(4, 4) > 0.0)) return false;
  out->board = o.board_index;
  out->c = x.tail<2>();
  out->var << cov(3, 3), cov(4, 4);
  return true;
}

}  // namespace

std::vector<BoardBend> EstimateBoardBends(const std::vector<BoardGeometry>& boards,
                                          const ObservationSet& set, const Pose& T_camera_lidar,
                                          const std::vector<Pose>& T_camera_board) {
  const bool refined = T_camera_board.size() == set.observations.size();
  std::vector<ObservationBend> fits;
  fits.reserve(set.observations.size());
  for (size_t i = 0; i < set.observations.size(); ++i) {
    const BoardObservation& o = set.observations[i];
    if (o.board_index < 0 || o.board_index >= static_cast<int>(boards.size())) continue;
    const Pose& T_cb = refined ? T_camera_board[i] : o.T_camera_board;
    ObservationBend f;
    if (FitObservation(boards[static_cast<size_t>(o.board_index)], set, o,
                       T_cb.inverse() * T_camera_lidar, &f))
      fits.push_back(f);
  }
  std::vector<BoardBend> out;
  for (int b = 0; b < static_cast<int>(boards.size()); ++b) {
    BoardBend bend;
    bend.board_index = b;
    // Inverse-variance mean per axis; the scatter of block means about it (blocks of
    // kBlockObservations consecutive observations) bounds its sigma from below.
    Eigen::Vector2d w_sum = Eigen::Vector2d::Zero(), wc_sum = Eigen::Vector2d::Zero();
    for (const ObservationBend& f : fits) {
      if (f.board != b) continue;
      ++bend.observations;
      w_sum += f.var.cwiseInverse();
      wc_sum += f.c.cwiseQuotient(f.var);
    }
    if (bend.observations == 0) continue;
    const Eigen::Vector2d mean = wc_sum.cwiseQuotient(w_sum);
    std::vector<Eigen::Vector2d> blocks;
    Eigen::Vector2d bw = Eigen::Vector2d::Zero(), bwc = Eigen::Vector2d::Zero();
    int in_block = 0;
    for (const ObservationBend& f : fits) {
      if (f.board != b) continue;
      bw += f.var.cwiseInverse();
      bwc += f.c.cwiseQuotient(f.var);
      if (++in_block == kBlockObservations) {
        blocks.push_back(bwc.cwiseQuotient(bw));
        bw.setZero();
        bwc.setZero();
        in_block = 0;
      }
    }
    if (in_block > 0) blocks.push_back(bwc.cwiseQuotient(bw));
    Eigen::Vector2d sigma = w_sum.cwiseInverse().cwiseSqrt();
    if (blocks.size() >= 2) {
      Eigen::Vector2d ss = Eigen::Vector2d::Zero();
      for (const Eigen::Vector2d& m : blocks) ss += (m - mean).cwiseAbs2();
      const double nb = static_cast<double>(blocks.size());
      sigma = sigma.cwiseMax((ss / (nb * (nb - 1.0))).cwiseSqrt());
    }
    bend.bend_u_m = mean.x();
    bend.bend_v_m = mean.y();
    bend.sigma_u_m = sigma.x();
    bend.sigma_v_m = sigma.y();
    out.push_back(bend);
  }
  return out;
}

}  // namespace calibd
