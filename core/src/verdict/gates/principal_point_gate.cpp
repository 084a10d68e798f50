#include "calibd/core/verdict/gates/principal_point_gate.hpp"

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/verdict/principal_point_check.hpp"
#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

namespace {

// The turn the principal point's sigma alone gives the result, deg.
double SigmaTurnDeg(const GateInput& in) {
  return PrincipalPointTurnDeg(in.quality.principal_point_sigma_px, in.camera);
}

double MaxTurnDeg(const GateInput& in) {
  return kPrincipalPointTurnTolerances * in.config.verify_rotation_deg;
}

}  // namespace

Reason CheckLensModel(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  // Groups of observations that disagree by far more than the turn that matters, and corners
  // that fit the lens model worse than detection explains: a wrong lens model. (Groups of a
  // short session can scatter as much with corners that fit: not refused for that alone.)
  const Eigen::Vector2d s = q.principal_point_sigma_px;
  const double sigma_turn_deg = SigmaTurnDeg(in);
  const double max_sigma_turn_deg = kPrincipalPointSigmaTurns * MaxTurnDeg(in);
  if (!(q.principal_point_fitted && sigma_turn_deg > max_sigma_turn_deg &&
        q.principal_point_residual_px > kLensMisfitResidualPx))
    return Reason::kNone;
  return Refuse(
      detail, Reason::kPrincipalPointMismatch,
      "the tags do not agree on the camera's principal point: +-" + FixedDecimal(s.x(), 1) +
          " / +-" + FixedDecimal(s.y(), 1) +
          " px from one group of observations to the next, a turn of " +
          FixedDecimal(sigma_turn_deg, 2) + " deg, more than " +
          FixedDecimal(max_sigma_turn_deg, 2) +
          " deg; their corners fit the configured lens with " +
          FixedDecimal(q.principal_point_residual_px, 2) +
          " px RMS: the camera's intrinsic calibration (its lens distortion or principal "
          "point) is likely wrong; calibrate the camera's intrinsics again (if they are "
          "right, boards closer to the camera and turned 20-40 deg let the tags check them)");
}

Reason CheckPrincipalPoint(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!q.principal_point_fitted) return Reason::kNone;
  // A principal point off by d turns the result by about d / f, which the LiDAR cannot see.
  const Eigen::Vector2d d = q.principal_point_shift_px;
  const double turn_deg = q.principal_point_turn_deg;
  const double chi2 = (d.cwiseQuotient(q.principal_point_sigma_px)).squaredNorm();
  const double sigma_turn_deg = SigmaTurnDeg(in);
  const double max_turn_deg = MaxTurnDeg(in);
  if (!(turn_deg + kPrincipalPointTurnSigmas * sigma_turn_deg > max_turn_deg &&
        chi2 > kPrincipalPointChiSquare))
    return Reason::kNone;
  return Refuse(detail, Reason::kPrincipalPointMismatch,
                "the tags put the camera's principal point " + FixedDecimal(d.x(), 1) + " px (+-" +
                    FixedDecimal(q.principal_point_sigma_px.x(), 1) + ") right and " +
                    FixedDecimal(d.y(), 1) + " px (+-" +
                    FixedDecimal(q.principal_point_sigma_px.y(), 1) +
                    ") down of the configured one, which turns the result by " +
                    FixedDecimal(turn_deg, 2) + " deg (+-" + FixedDecimal(sigma_turn_deg, 2) +
                    "), possibly more than " + FixedDecimal(max_turn_deg, 2) +
                    " deg: the camera's intrinsic calibration (its principal point, or its focal "
                    "length) is wrong or belongs to another camera; calibrate the camera's "
                    "intrinsics again");
}

Reason CheckStatedPrincipalPoint(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(q.principal_point_stated_chi2 > kStatedPrincipalPointChiSquare)) return Reason::kNone;
  const Eigen::Vector2d d = q.principal_point_shift_px;
  return Refuse(detail, Reason::kPrincipalPointMismatch,
                "the tags put the camera's principal point " + FixedDecimal(d.x(), 1) +
                    " px right and " + FixedDecimal(d.y(), 1) +
                    " px down of the configured one, beyond the +-" +
                    FixedDecimal(q.principal_point_stated_sigma_px, 1) +
                    " px its intrinsic calibration states (camera.principal_point_sigma_px; "
                    "chi-square " +
                    FixedDecimal(q.principal_point_stated_chi2, 1) + " against " +
                    FixedDecimal(kStatedPrincipalPointChiSquare, 2) +
                    "): the intrinsics are wrong, belong to another camera, or are less precise "
                    "than stated; calibrate the camera's intrinsics again");
}

}  // namespace calibd
