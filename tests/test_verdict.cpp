// The verdict's gates (verdict/verdict.hpp) on quality figures set by hand: a session that passes
// every gate, each gate refusing the figure it judges with its reason, and the order in which the
// gates are asked where one fault shows in several figures.

#include "calibd/core/verdict/verdict.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <functional>
#include <limits>
#include <string>

namespace calibd {
namespace {

// The figures of a clean session: every one well inside its gate.
QualityFigures Clean() {
  QualityFigures q;
  q.reprojection_mean_px = 1.0;
  q.reprojection_p95_px = 2.0;
  q.reprojection_gate_px = 8.0;
  q.residual_rms_m = 0.01;
  q.frames_used = 50;
  q.boards_used = 100;
  q.rotation_sigma_deg = 0.01;
  q.translation_sigma_m = 0.001;
  q.plane_conditioning = 5e-5;
  q.rotation_spread_deg = 0.02;
  q.translation_spread_m = 0.002;
  q.start_rotation_deg = 0.01;
  q.start_translation_m = 0.001;
  q.camera_scale_error = 0.001;
  q.camera_scale_sigma = 0.001;
  q.camera_scale_translation_m = 0.005;
  q.lidar_range_offset_m = 0.002;
  q.lidar_range_offset_sigma_m = 0.002;
  q.time_offset_fitted = true;
  q.time_offset_s = 0.001;
  q.time_offset_sigma_s = 0.001;
  q.principal_point_fitted = true;
  q.principal_point_shift_px = {1.0, 1.0};
  q.principal_point_sigma_px = {2.0, 2.0};
  q.principal_point_residual_px = 0.07;
  q.principal_point_turn_deg = std::hypot(1.0, 1.0) / 1000.0 * kRad2Deg;
  q.board_bend_id = 1;
  q.board_bend_m = 0.0005;
  q.board_bend_sigma_m = 0.0005;
  q.ring_elevation_rings = 40;
  q.ring_elevation_chi2 = 2.0;
  q.ring_elevation_rms_deg = 0.05;
  q.principal_point_stated_sigma_px = 1.0;
  q.principal_point_stated_chi2 = 0.5;
  q.rotation_clustered_sigma_deg = 0.01;
  q.rotation_statistical_deg = 0.03;
  q.translation_clustered_sigma_m = 0.001;
  q.rotation_systematic_deg = 0.1;
  q.translation_systematic_m = 0.01;
  q.translation_bound_range_offset_m = 0.008;
  q.rotation_bound_deg = 0.15;
  q.translation_bound_m = 0.012;
  return q;
}

struct Session {
  CameraIntrinsics camera;
  VerdictConfig config;
  QualityFigures q = Clean();
  double delta_rotation_deg = 0.5, delta_translation_m = 0.05;

  Session() { camera.fx = camera.fy = 1000.0; }
  Reason Verdict(std::string* detail) const {
    return FailedGate({camera, config, q, delta_rotation_deg, delta_translation_m}, detail);
  }
};

TEST(VerdictTest, ACleanSessionPassesEveryGate) {
  std::string detail;
  EXPECT_EQ(Session().Verdict(&detail), Reason::kNone) << detail;
}

struct Fault {
  const char* name;
  std::function<void(Session*)> apply;
  Reason reason;
  const char* words;  // in the detail
};

TEST(VerdictTest, EachGateRefusesTheFigureItJudges) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const Fault faults[] = {
      {"bent board", [](Session* s) { s->q.board_bend_m = 0.008; }, Reason::kBoardNotFlat,
       "bends 8.0 mm"},
      {"parallel planes", [](Session* s) { s->q.plane_conditioning = 1e-7; },
       Reason::kPoorObservability, "conditioning"},
      // Twice the sigma gate a site set: four times the boards (400) would bring it under.
      {"formal sigma",
       [](Session* s) {
         s->config.max_rotation_sigma_deg = 0.05;
         s->q.rotation_sigma_deg = 0.1;
       },
       Reason::kPoorObservability, "about 400 like them"},
      {"wrong lens",
       [](Session* s) {
         s->q.principal_point_sigma_px = {40.0, 40.0};
         s->q.principal_point_residual_px = 0.5;
       },
       Reason::kPrincipalPointMismatch, "do not agree"},
      {"principal point off",
       [](Session* s) {
         s->q.principal_point_shift_px = {20.0, 0.0};
         s->q.principal_point_sigma_px = {1.0, 1.0};
         s->q.principal_point_turn_deg = 20.0 / 1000.0 * kRad2Deg;
       },
       Reason::kPrincipalPointMismatch, "20.0 px (+-1.0) right"},
      {"tag size", [](Session* s) { s->q.camera_scale_error = 0.03; }, Reason::kCameraScaleMismatch,
       "3.00 % (+-0.10) longer"},
      {"range bias",
       [](Session* s) {
         s->q.lidar_range_offset_m = -0.03;
         s->q.lidar_range_offset_sigma_m = 0.003;
       },
       Reason::kLidarRangeOffset, "3.0 cm (+-0.3) shorter"},
      {"ring elevations",
       [](Session* s) {
         s->q.ring_elevation_chi2 = 20.0;
         s->q.ring_elevation_rms_deg = 0.2;
       },
       Reason::kLidarRingElevation, "0.200 deg RMS"},
      {"range offset unmeasured", [](Session* s) { s->q.lidar_range_offset_sigma_m = 0.1; },
       Reason::kPoorObservability, "range offset only to +-10.0 cm"},
      {"range offset not fitted", [nan](Session* s) { s->q.lidar_range_offset_sigma_m = nan; },
       Reason::kPoorObservability, "cannot measure the LiDAR's range offset"},
      {"small far tags", [](Session* s) { s->q.camera_scale_translation_m = 0.02; },
       Reason::kPoorObservability, "tags are too small"},
      {"camera late", [](Session* s) { s->q.time_offset_s = 0.2; }, Reason::kTimeOffset,
       "200.0 ms (+-1.0) later"},
      {"half-data spread", [](Session* s) { s->q.rotation_spread_deg = 0.5; },
       Reason::kUnstableSolution, "half-data"},
      {"another minimum", [](Session* s) { s->q.start_translation_m = 0.02; },
       Reason::kUnstableSolution, "more than one minimum"},
      {"reprojection", [](Session* s) { s->q.reprojection_mean_px = 9.0; },
       Reason::kHighReprojectionError, "mean 9.00 px above 8.00 px"},
      {"residual", [](Session* s) { s->q.residual_rms_m = 0.06; }, Reason::kHighResidual,
       "point-to-board RMS 0.0600 m"},
      {"intrinsics less precise than stated",
       [](Session* s) { s->q.principal_point_stated_chi2 = 12.0; }, Reason::kPrincipalPointMismatch,
       "beyond the +-1.0 px its intrinsic calibration states"},
      {"principal point known to no one",
       [](Session* s) {
         s->q.principal_point_stated_sigma_px = 0.0;
         s->q.rotation_systematic_deg = 0.5;
         s->q.rotation_bound_deg = 0.52;
       },
       Reason::kPoorObservability, "set camera.principal_point_sigma_px"},
      {"principal point less precise than the tolerance",
       [](Session* s) {
         s->q.rotation_systematic_deg = 0.4;
         s->q.rotation_bound_deg = 0.41;
       },
       Reason::kPoorObservability, "a more precise intrinsic calibration"},
      {"principal point stated sharper than the tags can check",
       [](Session* s) {
         s->q.principal_point_sigma_px = {2.0, 3.5};  // beyond kMaxStatedSharpening x 1 px
         s->q.rotation_systematic_deg = 0.4;
         s->q.rotation_bound_deg = 0.41;
       },
       Reason::kPoorObservability, "too loosely to check the intrinsic calibration's +-1.0 px"},
      {"range offset not told from the position",
       [](Session* s) {
         s->q.translation_bound_range_offset_m = 0.035;
         s->q.translation_bound_m = 0.04;
       },
       Reason::kPoorObservability, "boards to the sides as well"},
      {"a camera scale that moves the translation",
       [](Session* s) {
         s->q.camera_scale_error = 0.0008;
         s->q.camera_scale_sigma = 0.0002;
         s->q.translation_bound_scale_m = 0.025;
         s->q.translation_bound_m = 0.035;
       },
       Reason::kPoorObservability, "the camera's scale 0.08 +-0.02 % off the LiDAR's"},
      {"scattered boards",
       [](Session* s) {
         s->q.rotation_clustered_sigma_deg = 0.1;
         s->q.rotation_statistical_deg = 0.337;
         s->q.rotation_bound_deg = 0.35;
       },
       Reason::kPoorObservability, "the boards' own scatter (+-0.100 deg)"},
      {"scatter within the tolerance, a principal point the unbiased tags read beyond it",
       [](Session* s) {
         s->q.rotation_clustered_sigma_deg = 0.08;
         s->q.rotation_statistical_deg = 0.27;
         s->q.rotation_systematic_deg = 0.2;
         s->q.rotation_bound_deg = 0.33;
         s->q.principal_point_bound_corners = CornerBias::kNone;
       },
       Reason::kPoorObservability, "the tags put it 1.0 px right and 1.0 px down"},
      {"a camera scale that turns the result",
       [](Session* s) {
         s->q.camera_scale_error = 0.004;
         s->q.camera_scale_sigma = 0.001;
         s->q.rotation_bound_camera_scale_deg = 0.3;
         s->q.rotation_systematic_deg = 0.4;
         s->q.rotation_bound_deg = 0.41;
       },
       Reason::kPoorObservability,
       "the camera's scale against the LiDAR (its board distances 0.40"},
      {"no bound", [inf](Session* s) { s->q.rotation_bound_deg = s->q.translation_bound_m = inf; },
       Reason::kPoorObservability, "error could reach unknown deg"},
      {"beyond the mechanical tolerance", [](Session* s) { s->delta_translation_m = 0.3; },
       Reason::kDeltaBeyondTolerance, "exceeds 10.000 deg / 0.200 m"},
  };
  for (const Fault& f : faults) {
    Session s;
    f.apply(&s);
    std::string detail;
    EXPECT_EQ(s.Verdict(&detail), f.reason) << f.name << ": " << detail;
    EXPECT_NE(detail.find(f.words), std::string::npos) << f.name << ": " << detail;
  }
}

TEST(VerdictTest, TheGateThatNamesTheCauseIsAskedFirst) {
  std::string detail;
  // A bent board also shows as a range offset and a scale.
  Session bent;
  bent.q.board_bend_m = 0.008;
  bent.q.lidar_range_offset_m = 0.03;
  bent.q.lidar_range_offset_sigma_m = 0.003;
  bent.q.camera_scale_error = 0.03;
  EXPECT_EQ(bent.Verdict(&detail), Reason::kBoardNotFlat) << detail;
  // A wrong scale also spreads the boards' distances, and so the time offset.
  Session scaled;
  scaled.q.camera_scale_error = 0.03;
  scaled.q.time_offset_s = 0.2;
  EXPECT_EQ(scaled.Verdict(&detail), Reason::kCameraScaleMismatch) << detail;
  // Every quality gate before the change from the prior: a bad solution is not a bent bracket.
  Session far;
  far.q.residual_rms_m = 0.06;
  far.delta_rotation_deg = 20.0;
  EXPECT_EQ(far.Verdict(&detail), Reason::kHighResidual) << detail;
  // A fault the gates name widens the error bound too: the gate that names it answers.
  Session biased;
  biased.q.lidar_range_offset_m = -0.03;
  biased.q.lidar_range_offset_sigma_m = 0.003;
  biased.q.translation_bound_m = 0.05;
  EXPECT_EQ(biased.Verdict(&detail), Reason::kLidarRangeOffset) << detail;
  Session shifted;
  shifted.q.principal_point_stated_chi2 = 12.0;
  shifted.q.rotation_bound_deg = 0.5;
  EXPECT_EQ(shifted.Verdict(&detail), Reason::kPrincipalPointMismatch) << detail;
}

TEST(VerdictTest, AFigureAtItsGatePasses) {
  std::string detail;
  Session s;
  s.q.reprojection_mean_px = s.q.reprojection_gate_px;
  s.q.residual_rms_m = s.config.max_residual_rms_m;
  s.config.max_rotation_sigma_deg = 0.05;
  s.q.rotation_sigma_deg = s.config.max_rotation_sigma_deg;
  s.delta_rotation_deg = s.config.max_rotation_deg;
  s.q.rotation_bound_deg = s.config.max_rotation_bound_deg;
  s.q.translation_bound_m = s.config.max_translation_bound_m;
  EXPECT_EQ(s.Verdict(&detail), Reason::kNone) << detail;
}

TEST(VerdictTest, AFormalSigmaIsJudgedByTheErrorBoundUnlessASiteSetsAGate) {
  // By default the formal sigma is no gate of its own: a result whose sigma is large but whose
  // error bound lies inside the tolerance passes, one whose bound does not is refused by the
  // bound; a site's own gate still refuses it, naming the translation's gate alone when only
  // that one is set.
  std::string detail;
  Session s;
  s.q.rotation_sigma_deg = 0.1;
  s.q.translation_sigma_m = 0.02;
  EXPECT_EQ(s.Verdict(&detail), Reason::kNone) << detail;
  s.q.rotation_bound_deg = 2.0 * s.config.max_rotation_bound_deg;
  EXPECT_EQ(s.Verdict(&detail), Reason::kPoorObservability);
  EXPECT_EQ(detail.find("formal sigma"), std::string::npos) << detail;
  Session site;
  site.config.max_translation_sigma_m = 0.01;
  site.q.rotation_sigma_deg = 0.1;
  site.q.translation_sigma_m = 0.02;
  EXPECT_EQ(site.Verdict(&detail), Reason::kPoorObservability);
  EXPECT_NE(detail.find("above no gate / 0.0100 m"), std::string::npos) << detail;
}

TEST(VerdictTest, TheReprojectionGateWidensForASparseLidar) {
  const ReprojectionGateConfig c;
  EXPECT_DOUBLE_EQ(ReprojectionGatePx(c, 3325.0, 1.0),
                   3325.0 * c.max_reprojection_mean_deg * kDeg2Rad);
  EXPECT_DOUBLE_EQ(ReprojectionGatePx(c, 3325.0, 40.0), kReprojectionSpacingShare * 40.0);
}

// The gate is an angle: the same boards seen through a lens of a third of the focal length miss
// by a third of the pixels, and are judged the same. At fx = 3325 px it is the 8 px it was.
TEST(VerdictTest, TheReprojectionGateScalesWithTheFocalLength) {
  const ReprojectionGateConfig c;
  EXPECT_NEAR(ReprojectionAnglePx(c, 3325.0), 8.1, 0.05);
  EXPECT_DOUBLE_EQ(ReprojectionAnglePx(c, 1100.0) / ReprojectionAnglePx(c, 3300.0), 1.0 / 3.0);
  CameraIntrinsics long_lens, short_lens;
  long_lens.fx = long_lens.fy = 3300.0;
  short_lens.fx = short_lens.fy = 1100.0;
  EXPECT_DOUBLE_EQ(ReprojectionFocalPx(short_lens), 1100.0);
  for (const CameraIntrinsics& camera : {long_lens, short_lens}) {
    Session s;
    s.camera = camera;
    const double scale = camera.fx / 3300.0;
    s.q.reprojection_gate_px = ReprojectionGatePx(s.config, camera.fx, 0.0);
    std::string detail;
    s.q.reprojection_mean_px = 7.0 * scale;  // 0.12 deg
    EXPECT_EQ(s.Verdict(&detail), Reason::kNone) << detail;
    s.q.reprojection_mean_px = 9.0 * scale;  // 0.16 deg
    EXPECT_EQ(s.Verdict(&detail), Reason::kHighReprojectionError);
    EXPECT_NE(detail.find("deg at the camera's focal length"), std::string::npos) << detail;
  }
}

TEST(VerdictTest, VerifiedOnlyWithinBothVerificationTolerances) {
  const PriorToleranceConfig c;
  EXPECT_TRUE(WithinVerification(c, c.verify_rotation_deg, c.verify_translation_m));
  EXPECT_FALSE(WithinVerification(c, 2.0 * c.verify_rotation_deg, 0.0));
  EXPECT_FALSE(WithinVerification(c, 0.0, 2.0 * c.verify_translation_m));
}

TEST(VerdictTest, TooFewCorrespondencesNamesWhatIsShortAndWhen) {
  CorrespondenceCountConfig c;
  QualityFigures q = Clean();
  std::string detail;
  EXPECT_EQ(TooFewCorrespondences(q, c, "", &detail), Reason::kNone);
  q.boards_used = c.min_boards - 1;
  EXPECT_EQ(TooFewCorrespondences(q, c, " once 3 were dropped", &detail), Reason::kTooFewBoards);
  EXPECT_EQ(detail, "5 board correspondences once 3 were dropped, 6 needed");
  q.frames_used = 0;
  EXPECT_EQ(TooFewCorrespondences(q, c, "", &detail), Reason::kTooFewFrames);
}

}  // namespace
}  // namespace calibd
