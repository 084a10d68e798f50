// The session-level engine on real detections of simulated sessions: verdicts and reason codes
// for good and degenerate inputs.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <numeric>
#include <random>
#include <string>
#include <vector>

#include "calibd/core/engine/calibration_engine.hpp"
#include "calibd/core/verdict/measure_quality.hpp"
#include "recorded_session.hpp"
#include "short_session.hpp"
#include "small_camera.hpp"

namespace calibd {
namespace {

// 40 frame pairs spread over the default 20 s drive (6-30 m and back).
std::unique_ptr<testing::RecordedSession> Drive(sim::SessionOptions o) {
  return testing::Record(o, 40, 5);
}

// That drive with the prior 3 deg off, recorded once per process: the suite
// CalibrationEngineDefaultDriveTest runs as one ctest entry (tests/CMakeLists.txt), its cases
// sharing the recording (a copy where they change the observations).
sim::SessionOptions DefaultDriveOptions() {
  sim::SessionOptions o;
  o.prior_rot_deg = 3.0;
  return o;
}
const testing::RecordedSession& DefaultDrive() {
  static const std::unique_ptr<testing::RecordedSession> r = Drive(DefaultDriveOptions());
  return *r;
}

// `poses` still poses, one every 2 s, of `boards` 0.9 m boards (0.702 m tags), seen by a
// 1920 x 1200 camera of focal length `f_px` with its principal point in the middle.
sim::SessionOptions StillPoses(const std::string& lidar, int poses, int boards, double f_px) {
  sim::SessionOptions o;
  o.lidar_model = lidar;
  o.trajectory.mode = "stills";
  o.trajectory.rate_hz = 0.5;
  o.trajectory.duration_s = poses / o.trajectory.rate_hz;
  o.workshop.num_boards = boards;
  o.workshop.board_width_m = o.workshop.board_height_m = 0.9;
  o.workshop.tag_size_m = 0.702;
  o.camera.width = 1920;
  o.camera.height = 1200;
  o.camera.fx = o.camera.fy = f_px;
  o.camera.cx = 959.5;
  o.camera.cy = 599.5;
  return o;
}

// The result's error against the truth lies inside its own 99 % bound.
void ExpectInsideItsBound(const CalibrationOutcome& out, const Pose& truth) {
  const double error_deg = RotationAngle(out.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad;
  const double error_m = (out.T_camera_lidar.translation() - truth.translation()).norm();
  std::printf("error %.3f deg / %.4f m, bound %.3f deg / %.4f m\n", error_deg, error_m,
              out.quality.rotation_bound_deg, out.quality.translation_bound_m);
  EXPECT_LT(error_deg, out.quality.rotation_bound_deg);
  EXPECT_LT(error_m, out.quality.translation_bound_m);
}

// Two boards, the second 70 % the size of the first, and a config that gives each the other's id:
// the camera puts both at the wrong distance, nothing lines up, and the refusal names the swap
// (board_swap_check.hpp). The same frames with the ids right calibrate.
TEST(CalibrationEngineTest, BoardIdsSwappedBetweenBoardsOfDifferentSizesAreNamed) {
  sim::SessionOptions o;
  o.workshop.num_boards = 2;
  o.workshop.board_scales = {1.0, 0.7};
  o.prior_rot_deg = 3.0;
  o.prior_trans_m = 0.03;
  // The swap is named from the drive's span at half its frames; the right ids take all 40 for
  // an update (20 frames of two boards end short of the error bound's tolerance).
  auto swapped = testing::Record(o, 20, 10, 0, nullptr, [](CalibConfig* c) {
    std::swap(c->boards[0].board_id, c->boards[1].board_id);
    std::swap(c->boards[0].tag_id, c->boards[1].tag_id);
  });
  const CalibrationOutcome refused =
      Calibrate(swapped->config, swapped->obs, swapped->projection, testing::ShortSessionEngine());
  EXPECT_EQ(refused.verdict, CalibrationOutcome::Verdict::kRejected);
  EXPECT_EQ(refused.reason, Reason::kBoardIdsSwapped) << refused.detail;
  EXPECT_NE(refused.detail.find("boards 1 (tag id 1, 0.600 x 0.600 m) and 0 (tag id 0, 0.420 x "
                                "0.420 m) are each other's"),
            std::string::npos)
      << refused.detail;
  auto right = testing::Record(o, 40, 5);
  const CalibrationOutcome updated =
      Calibrate(right->config, right->obs, right->projection, testing::ShortSessionEngine());
  ASSERT_EQ(updated.verdict, CalibrationOutcome::Verdict::kUpdated)
      << updated.reason << ": " << updated.detail;
  ExpectInsideItsBound(updated, right->session.T_camera_lidar());
}

// The default drive with its three boards each bent 15 mm (towards the sensors, away, towards):
// refused as not flat, naming the most bent board; the same drive with flat boards calibrates,
// its boards measured flat within 2 mm (board_flatness.hpp).
TEST(CalibrationEngineDefaultDriveTest, ABentBoardIsNamedAndFlatOnesPass) {
  const testing::RecordedSession* flat = &DefaultDrive();
  const CalibrationOutcome updated =
      Calibrate(flat->config, flat->obs, flat->projection, testing::ShortSessionEngine());
  EXPECT_EQ(updated.verdict, CalibrationOutcome::Verdict::kUpdated)
      << updated.reason << ": " << updated.detail;
  ASSERT_GE(updated.quality.board_bend_id, 0);
  EXPECT_LT(std::fabs(updated.quality.board_bend_m), 0.002);
  sim::SessionOptions o = DefaultDriveOptions();
  o.workshop.board_bows_m = {0.015, -0.015, 0.015};
  auto bent = Drive(o);
  const CalibrationOutcome refused =
      Calibrate(bent->config, bent->obs, bent->projection, testing::ShortSessionEngine());
  EXPECT_EQ(refused.verdict, CalibrationOutcome::Verdict::kRejected);
  EXPECT_EQ(refused.reason, Reason::kBoardNotFlat) << refused.detail;
  EXPECT_NEAR(std::fabs(refused.quality.board_bend_m), 0.015, 0.003) << refused.detail;
  EXPECT_NE(refused.detail.find("flatten or replace the board"), std::string::npos);
}

TEST(CalibrationEngineDefaultDriveTest, UpdatedWhenThePriorIsOffAndVerifiedWhenItIsRight) {
  const testing::RecordedSession* r = &DefaultDrive();
  const CalibrationOutcome updated =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  std::printf("good session: plane conditioning %.2e, sigma %.4f deg\n",
              updated.quality.plane_conditioning, updated.quality.rotation_sigma_deg);
  ASSERT_EQ(updated.verdict, CalibrationOutcome::Verdict::kUpdated)
      << updated.reason << ": " << updated.detail;
  const Pose truth = r->session.T_camera_lidar();
  EXPECT_LT(RotationAngle(updated.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad, 0.1);
  EXPECT_LT((updated.T_camera_lidar.translation() - truth.translation()).norm(), 0.015);
  EXPECT_NEAR(updated.delta_rotation_deg, 3.0, 0.15);

  // The same observations with the truth as the prior: the prior is confirmed, not replaced.
  CalibConfig right = r->config;
  right.prior_T_camera_lidar = truth;
  const CalibrationOutcome verified =
      Calibrate(right, r->obs, r->projection, testing::ShortSessionEngine());
  EXPECT_EQ(verified.verdict, CalibrationOutcome::Verdict::kVerified)
      << verified.reason << ": " << verified.detail << " delta " << verified.delta_rotation_deg;
}

// A quarter-size camera (960 x 480) sees the 0.48 m tags of a drive to 30 m at 13-80 px: they
// measure their distance too loosely for a centimetre translation, and their corner bias passes
// for a scale or a time offset. The session is refused as poorly observed, with what to change;
// the same camera with the boards within 7 m calibrates within tolerance (over 120 pairs: over 60,
// its scale known to +-0.17 % turns its result by up to 0.6 deg, beyond even a short session's
// tolerance).
TEST(CalibrationEngineTest, SmallFarTagsAreRefusedNotTrusted) {
  sim::SessionOptions o;
  o.lidar_model = "m1";
  o.camera = testing::SmallCamera();
  o.prior_rot_deg = 3.0;
  o.prior_trans_m = 0.08;
  auto far = testing::Record(o, 60, 3);
  const CalibrationOutcome refused =
      Calibrate(far->config, far->obs, far->projection, testing::ShortSessionEngine());
  std::printf("small far tags: %s (%s), +-%.1f cm from the scale\n", VerdictName(refused.verdict),
              std::string(NameOf(refused.reason)).c_str(),
              refused.quality.camera_scale_translation_m * 100.0);
  EXPECT_EQ(refused.reason, Reason::kPoorObservability) << refused.detail;
  EXPECT_NE(refused.detail.find("bring the boards closer"), std::string::npos) << refused.detail;

  o.trajectory.min_distance_m = 2.5;
  o.trajectory.max_distance_m = 7.0;
  auto near = testing::Record(o, 120, 3);
  const CalibrationOutcome updated =
      Calibrate(near->config, near->obs, near->projection, testing::ShortSessionEngine());
  ASSERT_EQ(updated.verdict, CalibrationOutcome::Verdict::kUpdated)
      << updated.reason << ": " << updated.detail;
  const Pose truth = near->session.T_camera_lidar();
  EXPECT_LT(RotationAngle(updated.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad, 0.15);
  EXPECT_LT((updated.T_camera_lidar.translation() - truth.translation()).norm(), 0.02);
  EXPECT_LT(updated.quality.camera_scale_translation_m,
            kScaleTranslationTolerances * VerdictConfig{}.verify_translation_m);
}

// The reprojection gate (paper Table I metric) follows the LiDAR's point spacing on the boards:
// a Mid-360 (non-repetitive, about 1 point per square degree a sweep) puts tens of points on a
// board, whose own fit then places the tag corners tens of pixels off whatever the extrinsic.
// Still poses of a board, 3 sweeps each, are accepted with their error inside their bound, the
// gate well above the angle's (a dense LiDAR's drive keeps the angle's:
// PerCorrespondenceReprojectionErrorsAreTheQualityFigures). Their clustered covariance comes
// out narrower than the formal one here (a sparse LiDAR's few points per board): the bound takes
// the formal one, or this result, 0.25 deg off, lay outside it.
TEST(CalibrationEngineTest, TheReprojectionGateFollowsTheLidarsPointSpacing) {
  sim::SessionOptions o = StillPoses("mid360", 40, 1, 2200.0);
  o.seed = 4;
  o.stills.frames_per_pose = 3;
  o.stills.min_distance_m = 3.0;
  o.stills.max_distance_m = 6.0;
  auto sparse = testing::Record(o, 120, 1);
  // 40 poses of one board measure the extrinsic to about 0.12 deg (formal), which takes the
  // short sessions' tolerance of the error bound.
  const CalibrationOutcome out =
      Calibrate(sparse->config, sparse->obs, sparse->projection, testing::ShortSessionEngine());
  const QualityFigures& q = out.quality;
  std::printf("mid360 stills: reprojection %.2f px, point spacing %.1f px, gate %.2f px\n",
              q.reprojection_mean_px, q.lidar_spacing_px, q.reprojection_gate_px);
  ASSERT_EQ(out.verdict, CalibrationOutcome::Verdict::kUpdated) << out.reason << ": " << out.detail;
  ExpectInsideItsBound(out, sparse->session.T_camera_lidar());
  // Its statistical part at least the formal covariance's (along its worst direction), which is
  // the wider here; and no wider than such a session needs.
  EXPECT_GE(q.rotation_statistical_deg, kBoundQuantile1d * q.rotation_sigma_deg);
  EXPECT_LT(q.rotation_bound_deg, 0.45);
  // The gate applied is the spacing's, well above the angle's, which the mean error reaches.
  const VerdictConfig v;
  EXPECT_DOUBLE_EQ(q.reprojection_gate_px, kReprojectionSpacingShare * q.lidar_spacing_px);
  const double angle_gate_px = ReprojectionAnglePx(v, ReprojectionFocalPx(sparse->config.camera));
  EXPECT_GT(q.reprojection_gate_px, 2.0 * angle_gate_px);
  EXPECT_GT(q.reprojection_mean_px, 0.8 * angle_gate_px);
}

TEST(CalibrationEngineTest, OneBoardIsRejectedForObservability) {
  sim::SessionOptions o;
  o.workshop.num_boards = 1;
  auto r = testing::Record(o, 20, 10);  // the drive's span, half its frames
  const CalibrationOutcome out =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  EXPECT_EQ(out.verdict, CalibrationOutcome::Verdict::kRejected);
  EXPECT_EQ(out.reason, Reason::kPoorObservability) << out.detail;
  std::printf("one board: plane conditioning %.2e\n", out.quality.plane_conditioning);
}

TEST(CalibrationEngineTest, ParallelCoplanarBoardsAreRejectedForObservability) {
  sim::SessionOptions o;
  o.workshop.layout = "line";  // side by side, all facing the vehicle: one plane
  o.trajectory.mode = "static";
  o.trajectory.static_distance_m = 8.0;
  auto r = testing::Record(o, 12, 5);  // a still view: more frames see the same plane
  const CalibrationOutcome out =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  EXPECT_EQ(out.verdict, CalibrationOutcome::Verdict::kRejected);
  EXPECT_EQ(out.reason, Reason::kPoorObservability) << out.detail;
  std::printf("parallel boards: plane conditioning %.2e\n", out.quality.plane_conditioning);
}

TEST(CalibrationEngineTest, OnlyFarFramesAreRejectedForTheirPrecision) {
  // Boards only at 25-30 m (paper Table II, "far"): sparse LiDAR boards and PnP poses uncertain
  // by degrees leave the translation weakly constrained (measured, seed 1: error 0.10 deg /
  // 5 cm, formal sigma 1.1 cm). The precision gates must catch it, never a silent result.
  sim::SessionOptions o;
  o.trajectory.mode = "far";
  o.prior_rot_deg = 3.0;
  o.prior_trans_m = 0.03;
  auto r = Drive(o);
  const CalibrationOutcome out =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  std::printf("only far: %s (%s) sigma %.4f deg / %.4f m, spread %.4f deg / %.4f m, %.2f-%.2f m\n",
              VerdictName(out.verdict), NameOf(out.reason).data(), out.quality.rotation_sigma_deg,
              out.quality.translation_sigma_m, out.quality.rotation_spread_deg,
              out.quality.translation_spread_m, out.quality.min_distance_m,
              out.quality.max_distance_m);
  EXPECT_GT(out.quality.min_distance_m, 24.0);
  EXPECT_GT(out.quality.boards_used, 60);  // not rejected for a lack of data
  EXPECT_TRUE(out.solved);                 // the estimate is there for diagnosis
  EXPECT_EQ(out.verdict, CalibrationOutcome::Verdict::kRejected);
  EXPECT_TRUE(out.reason == Reason::kPoorObservability || out.reason == Reason::kUnstableSolution)
      << out.reason << ": " << out.detail;
}

TEST(CalibrationEngineDefaultDriveTest,
     ClustersThatAreNotOnTheirBoardAreDroppedBeforeTheFinalSolve) {
  // Every tenth LiDAR board of the default drive moved 0.45 m sideways (horizontally, across its
  // line of sight), as furniture beside a board: still overlapping its predicted region (the
  // grid search pairs it), but mostly off the board. The solve drops those correspondences and
  // its answer stays that of the clean drive.
  const testing::RecordedSession* r = &DefaultDrive();
  const Pose truth = r->session.T_camera_lidar();
  SessionObservations obs = r->obs;
  int moved = 0;
  for (size_t j = 0; j < obs.lidar.size(); j += 10, ++moved) {
    const auto& c = obs.lidar[j];
    const Eigen::Vector3f ray = obs.points[static_cast<size_t>(c.first_point)];
    const Eigen::Vector3f across = 0.45f * Eigen::Vector3f(-ray.y(), ray.x(), 0.0f).normalized();
    for (int k = c.first_point; k < c.first_point + c.num_points; ++k)
      obs.points[static_cast<size_t>(k)] += across;
  }
  const CalibrationOutcome out =
      Calibrate(r->config, obs, r->projection, testing::ShortSessionEngine());
  ASSERT_TRUE(out.solved) << out.reason << ": " << out.detail;
  std::printf("moved %d clusters: %d correspondences dropped, error %.4f deg, %.4f m\n", moved,
              out.dropped_correspondences,
              RotationAngle(out.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad,
              (out.T_camera_lidar.translation() - truth.translation()).norm());
  EXPECT_GE(out.dropped_correspondences, moved * 8 / 10);
  EXPECT_LE(out.dropped_correspondences, moved * 12 / 10);
  EXPECT_EQ(out.verdict, CalibrationOutcome::Verdict::kUpdated) << out.reason << ": " << out.detail;
  EXPECT_LT(RotationAngle(out.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad, 0.1);
  EXPECT_LT((out.T_camera_lidar.translation() - truth.translation()).norm(), 0.015);
}

TEST(CalibrationEngineTest, PointsOfTheStandUnderABoardAreTrimmedBeforeTheFinalSolve) {
  // Still poses of one board on a tripod before a VLP-16: the segmentation joins the tripod's
  // column to the board (a few returns a ring, 3-4 cm behind it), and the box cost pulls the
  // board towards them against the one ring near its far edge. The solve trims the points
  // beyond the board's outline and solves again. Without the trim, seed 3 ends 1.9 cm off
  // (1.8 cm of it vertical), seeds 1 and 2 1.0 and 0.4 cm; with it 0.8, 0.6 and 0.5 cm.
  for (const unsigned seed : {1u, 2u, 3u}) {
    sim::SessionOptions o = StillPoses("vlp16", 24, 1, 1100.0);
    o.seed = seed;
    o.stills.frames_per_pose = 2;
    auto r = testing::Record(o, 48, 1);
    const CalibrationOutcome out =
        Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
    ASSERT_TRUE(out.solved) << out.reason << ": " << out.detail;
    const Pose truth = r->session.T_camera_lidar();
    const Eigen::Vector3d error = out.T_camera_lidar.translation() - truth.translation();
    std::printf("seed %u: %d points trimmed, error %.3f deg, (%.4f %.4f %.4f) m\n", seed,
                out.points_off_their_boards,
                RotationAngle(out.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad, error.x(),
                error.y(), error.z());
    EXPECT_GT(out.points_off_their_boards, 0);
    EXPECT_LT(error.norm(), 0.01);
    ExpectInsideItsBound(out, truth);
  }
}

TEST(CalibrationEngineDefaultDriveTest, ARefusalForItsSigmaSaysHowManyBoardsWouldDo) {
  // The default drive, with the rotation sigma gate set to half of what it achieves: four times
  // the boards would halve the sigma, and the refusal says so.
  const testing::RecordedSession* r = &DefaultDrive();
  const CalibrationOutcome first =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_TRUE(first.solved) << first.reason << ": " << first.detail;
  EngineConfig strict = testing::ShortSessionEngine();
  strict.verdict.max_rotation_sigma_deg = first.quality.rotation_sigma_deg / 2.0;
  const CalibrationOutcome out = Calibrate(r->config, r->obs, r->projection, strict);
  EXPECT_EQ(out.reason, Reason::kPoorObservability) << out.detail;
  const int boards = out.quality.boards_used;
  EXPECT_NE(out.detail.find(std::to_string(boards) + " boards; about " +
                            std::to_string(4 * boards) + " like them"),
            std::string::npos)
      << out.detail;
}

// The start checks solve again from starts 3 deg / 5 cm off the solution: on the default drive
// they end on it (a few hundredths of a degree apart: half the points each), inside the gate;
// a gate below that refuses as unstable and says what the solves did; 0 checks skip them.
TEST(CalibrationEngineDefaultDriveTest, SolvesFromOtherStartsEndOnTheSolutionOrTheVerdictRefuses) {
  const testing::RecordedSession* r = &DefaultDrive();
  const CalibrationOutcome first =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_EQ(first.verdict, CalibrationOutcome::Verdict::kUpdated) << first.reason << first.detail;
  EXPECT_GT(first.quality.start_rotation_deg, 0.0);
  EXPECT_LT(first.quality.start_rotation_deg, 0.5 * VerdictConfig{}.max_start_rotation_deg);
  EXPECT_LT(first.quality.start_translation_m, 0.5 * VerdictConfig{}.max_start_translation_m);
  EngineConfig strict = testing::ShortSessionEngine();
  strict.verdict.max_start_rotation_deg = first.quality.start_rotation_deg / 2.0;
  const CalibrationOutcome out = Calibrate(r->config, r->obs, r->projection, strict);
  EXPECT_EQ(out.reason, Reason::kUnstableSolution) << out.detail;
  EXPECT_NE(out.detail.find("solves started 3 deg / 0.05 m away end"), std::string::npos)
      << out.detail;
  EngineConfig none = testing::ShortSessionEngine();
  none.start_checks = 0;
  const CalibrationOutcome skipped = Calibrate(r->config, r->obs, r->projection, none);
  EXPECT_EQ(skipped.verdict, CalibrationOutcome::Verdict::kUpdated) << skipped.detail;
  EXPECT_EQ(skipped.quality.start_rotation_deg, 0.0);
}

// A tag size (or focal length) wrong by a factor makes every PnP distance as much too long: the
// camera and the LiDAR disagree on the boards' distances in proportion to them, which no
// extrinsic explains. The correct session measures well under the gate; 1 % is measured and
// corrected (the result lands on the truth, and says what was corrected); 2 %, beyond
// max_camera_scale_error, is refused and says by how much and what to check.
TEST(CalibrationEngineDefaultDriveTest, ACameraScaleErrorIsCorrectedOrRefusedAsAScaleMismatch) {
  const testing::RecordedSession* r = &DefaultDrive();
  const Pose truth = r->session.T_camera_lidar();
  const CalibrationOutcome good =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_EQ(good.verdict, CalibrationOutcome::Verdict::kUpdated) << good.reason << good.detail;
  ASSERT_TRUE(std::isfinite(good.quality.camera_scale_error));
  EXPECT_LT(std::fabs(good.quality.camera_scale_error),
            0.5 * VerdictConfig{}.max_camera_scale_error)
      << "sigma " << good.quality.camera_scale_sigma;
  // The drive measures the scale to within half the verification tolerance's worth of translation.
  EXPECT_LT(good.quality.camera_scale_translation_m, 0.5 * VerdictConfig{}.verify_translation_m);
  // The configuration's tags `factor` times the printed ones: PnP's distances are as much long.
  auto tags_configured_larger = [&](double factor, CalibConfig* config) {
    for (BoardGeometry& g : config->boards) g.tag_size_m *= factor;
    SessionObservations scaled = r->obs;
    for (auto& c : scaled.camera) c.T_camera_board.translation() *= factor;
    return scaled;
  };
  CalibConfig one_percent = r->config;
  const SessionObservations one = tags_configured_larger(1.01, &one_percent);
  const CalibrationOutcome corrected =
      Calibrate(one_percent, one, r->projection, testing::ShortSessionEngine());
  ASSERT_EQ(corrected.verdict, CalibrationOutcome::Verdict::kUpdated)
      << corrected.reason << ": " << corrected.detail;
  EXPECT_NEAR(corrected.quality.camera_scale_corrected, 0.01, 0.003);
  EXPECT_NEAR(corrected.quality.camera_scale_error, corrected.quality.camera_scale_corrected,
              3.0 * corrected.quality.camera_scale_sigma);
  EXPECT_LT(RotationAngle(corrected.T_camera_lidar.linear(), truth.linear()) / kDeg2Rad, 0.1);
  EXPECT_LT((corrected.T_camera_lidar.translation() - truth.translation()).norm(), 0.015);
  EXPECT_NE(corrected.detail.find("longer than the LiDAR's and were corrected"), std::string::npos)
      << corrected.detail;
  CalibConfig two_percent = r->config;
  const SessionObservations two = tags_configured_larger(1.02, &two_percent);
  const CalibrationOutcome out =
      Calibrate(two_percent, two, r->projection, testing::ShortSessionEngine());
  EXPECT_EQ(out.reason, Reason::kCameraScaleMismatch) << out.detail;
  EXPECT_NEAR(out.quality.camera_scale_error, good.quality.camera_scale_error + 0.02, 0.003);
  EXPECT_EQ(out.quality.camera_scale_corrected, 0.0);
  EXPECT_NE(out.detail.find("longer than the LiDAR's"), std::string::npos) << out.detail;
  EXPECT_NE(out.detail.find("tag size"), std::string::npos) << out.detail;
}

// Boards ahead of a driving car cannot tell a range offset from a translation by their plane
// distances; their in-plane centres, left and right of the LiDAR's axis, can (range_offset.hpp).
// The clean drive measures none; every range 3 cm long is refused as a range offset; and a drive
// that does not measure the offset at all (to kRangeOffsetSigmaTolerances verification
// tolerances) is refused as poorly observed.
TEST(CalibrationEngineDefaultDriveTest, ALidarRangeOffsetIsMeasuredWhileDriving) {
  const testing::RecordedSession* r = &DefaultDrive();
  const CalibrationOutcome good =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_EQ(good.verdict, CalibrationOutcome::Verdict::kUpdated) << good.reason << good.detail;
  EXPECT_LT(good.quality.lidar_range_offset_sigma_m,
            kMeasuredRangeOffsetShare * VerdictConfig{}.max_lidar_range_offset_m);
  EXPECT_LT(std::fabs(good.quality.lidar_range_offset_m), VerdictConfig{}.max_lidar_range_offset_m);
  SessionObservations biased = r->obs;
  for (auto& p : biased.points) p += 0.03f * p.normalized();
  const CalibrationOutcome out =
      Calibrate(r->config, biased, r->projection, testing::ShortSessionEngine());
  std::printf("range offset while driving: clean %.4f +- %.4f m, 3 cm long %.4f +- %.4f m\n",
              good.quality.lidar_range_offset_m, good.quality.lidar_range_offset_sigma_m,
              out.quality.lidar_range_offset_m, out.quality.lidar_range_offset_sigma_m);
  EXPECT_EQ(out.reason, Reason::kLidarRangeOffset) << out.detail;
  EXPECT_NEAR(out.quality.lidar_range_offset_m, 0.03, 0.01);
  // A verification tolerance so strict that the clean drive does not measure the offset to it.
  EngineConfig strict = testing::ShortSessionEngine();
  strict.verdict.verify_translation_m =
      good.quality.lidar_range_offset_sigma_m / kRangeOffsetSigmaTolerances / 1.5;
  const CalibrationOutcome unsure = Calibrate(r->config, r->obs, r->projection, strict);
  EXPECT_EQ(unsure.reason, Reason::kPoorObservability) << unsure.detail;
  EXPECT_NE(unsure.detail.find("range offset"), std::string::npos) << unsure.detail;
}

// Still poses of two boards turned and placed across the field of view: their directions tell a
// constant LiDAR range offset from a translation. The clean session measures no offset; every
// range 4 cm long (a LiDAR's range calibration off) is refused, and the refusal says what to
// check.
TEST(CalibrationEngineTest, ALidarRangeOffsetIsRefusedWhereTheBoardsDirectionsShowIt) {
  sim::SessionOptions o = StillPoses("m1", 24, 2, 1100.0);
  o.prior_rot_deg = 3.0;
  auto r = testing::Record(o, 24, 1);
  const CalibrationOutcome good =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_TRUE(good.solved) << good.reason << ": " << good.detail;
  EXPECT_NE(good.reason, Reason::kLidarRangeOffset) << good.detail;
  ASSERT_TRUE(std::isfinite(good.quality.lidar_range_offset_m));
  EXPECT_LT(good.quality.lidar_range_offset_sigma_m, 0.01);
  EXPECT_LT(std::fabs(good.quality.lidar_range_offset_m), 0.01);
  SessionObservations biased = r->obs;
  for (auto& p : biased.points) p += 0.04f * p.normalized();
  const CalibrationOutcome out =
      Calibrate(r->config, biased, r->projection, testing::ShortSessionEngine());
  std::printf("range offset: clean %.4f +- %.4f m (%s), 4 cm long %.4f +- %.4f m\n",
              good.quality.lidar_range_offset_m, good.quality.lidar_range_offset_sigma_m,
              VerdictName(good.verdict), out.quality.lidar_range_offset_m,
              out.quality.lidar_range_offset_sigma_m);
  EXPECT_EQ(out.reason, Reason::kLidarRangeOffset) << out.detail;
  EXPECT_GT(out.quality.lidar_range_offset_m, 0.02);
  EXPECT_NE(out.detail.find("longer than the camera's board distances say"), std::string::npos)
      << out.detail;
}

// Calibrate's optional per-correspondence errors (for reports): one per correspondence, and
// they are the quality figure's own (each board's 4 corners: the mean of the means is the mean).
TEST(CalibrationEngineDefaultDriveTest, PerCorrespondenceReprojectionErrorsAreTheQualityFigures) {
  const testing::RecordedSession* r = &DefaultDrive();
  ObservationSet corr;
  std::vector<double> px{1.0, 2.0};  // replaced, not appended to
  const CalibrationOutcome out =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine(), &corr, &px);
  ASSERT_TRUE(out.solved) << out.reason << ": " << out.detail;
  ASSERT_EQ(px.size(), corr.observations.size());
  double sum = 0.0;
  int finite = 0;
  for (double e : px)
    if (std::isfinite(e)) {
      sum += e;
      ++finite;
    }
  EXPECT_GT(finite, static_cast<int>(px.size()) * 9 / 10);
  EXPECT_NEAR(sum / finite, out.quality.reprojection_mean_px,
              0.05 * out.quality.reprojection_mean_px);
  // An OT128's drive resolves the boards finely: the configured gate holds.
  const VerdictConfig v;
  const double angle_px = ReprojectionAnglePx(v, ReprojectionFocalPx(r->config.camera));
  EXPECT_DOUBLE_EQ(out.quality.reprojection_gate_px, angle_px);
  EXPECT_LT(kReprojectionSpacingShare * out.quality.lidar_spacing_px, angle_px);
  // Stopped before the solve: none.
  SessionObservations camera_only = r->obs;
  camera_only.lidar.clear();
  Calibrate(r->config, camera_only, r->projection, testing::ShortSessionEngine(), &corr, &px);
  EXPECT_TRUE(px.empty());
}

// An OT128's clouds under a Mid-360's model (a user's config naming the wrong LiDAR): a third of
// the points fall outside the model's field of view, and the verdict says so before the
// detections made on the wrong grid are used. The right model leaves none out.
TEST(CalibrationEngineTest, CloudsFromAnotherLidarModelAreRefused) {
  sim::SessionOptions o;
  o.prior_rot_deg = 3.0;
  LidarKind kind;
  ASSERT_TRUE(LidarKindFromName("mid360", &kind, nullptr));
  const LidarModel mid360 = MakeLidarModel(kind);
  auto wrong = testing::Record(o, 8, 20, 0, &mid360);
  const CalibrationOutcome out =
      Calibrate(wrong->config, wrong->obs, wrong->projection, testing::ShortSessionEngine());
  EXPECT_EQ(out.reason, Reason::kLidarModelMismatch) << out.detail;
  EXPECT_NE(out.detail.find("(mid360)"), std::string::npos) << out.detail;
  EXPECT_GT(wrong->obs.lidar_outside_points, wrong->obs.lidar_valid_points / 5);
  auto right = testing::Record(o, 8, 20);
  EXPECT_GT(right->obs.lidar_valid_points, 8 * 10000);
  EXPECT_EQ(right->obs.lidar_outside_points, 0);
}

// Frame pairs that arrive shuffled, some twice (a log written out of order, a replay repeating
// pairs): the engine works on them in capture order, each once, and gives the same answer as on
// the recording; its correspondences still name the frames and clusters it was given.
TEST(CalibrationEngineTest, PairsOutOfOrderOrRepeatedAreTakenInCaptureOrderOnce) {
  sim::SessionOptions o;
  o.prior_rot_deg = 3.0;
  auto r = testing::Record(o, 20, 10);
  const CalibrationOutcome recorded =
      Calibrate(r->config, r->obs, r->projection, testing::ShortSessionEngine());
  ASSERT_TRUE(recorded.solved) << recorded.reason << ": " << recorded.detail;
  EXPECT_EQ(recorded.frames_out_of_order, 0);
  EXPECT_EQ(recorded.duplicate_frames, 0);

  std::vector<int> frames(static_cast<size_t>(r->obs.num_frames));
  std::iota(frames.begin(), frames.end(), 0);
  std::shuffle(frames.begin(), frames.end(), std::mt19937_64(7));
  for (int f : {3, 11, 17}) frames.push_back(f);
  const SessionObservations arrived =
      SelectFrames(r->obs, frames, std::vector<char>(r->obs.camera.size(), 1),
                   std::vector<char>(r->obs.lidar.size(), 1));
  ObservationSet corr;
  const CalibrationOutcome out =
      Calibrate(r->config, arrived, r->projection, testing::ShortSessionEngine(), &corr);
  EXPECT_EQ(out.verdict, recorded.verdict) << out.reason << ": " << out.detail;
  EXPECT_GT(out.frames_out_of_order, 5);
  EXPECT_EQ(out.duplicate_frames, 3);
  EXPECT_LT(RotationAngle(out.T_camera_lidar.linear(), recorded.T_camera_lidar.linear()) / kDeg2Rad,
            1e-6);
  EXPECT_LT((out.T_camera_lidar.translation() - recorded.T_camera_lidar.translation()).norm(),
            1e-9);
  ASSERT_FALSE(corr.observations.empty());
  for (const BoardObservation& b : corr.observations) {
    ASSERT_GE(b.lidar_cluster, 0);
    const auto& cluster = arrived.lidar[static_cast<size_t>(b.lidar_cluster)];
    EXPECT_EQ(cluster.frame, b.frame);
    // Its points, less those off the board (a stand's, trimmed: at most half of them).
    EXPECT_LE(b.num_points, cluster.num_points);
    EXPECT_GE(2 * b.num_points, cluster.num_points);
  }
}

TEST(CalibrationEngineDefaultDriveTest, NoLidarBoardsOrNoCameraBoardsAreExplicit) {
  const testing::RecordedSession* r = &DefaultDrive();
  SessionObservations camera_only = r->obs;
  camera_only.lidar.clear();
  const CalibrationOutcome no_lidar =
      Calibrate(r->config, camera_only, r->projection, testing::ShortSessionEngine());
  EXPECT_EQ(no_lidar.reason, Reason::kNoLidarBoards);
  EXPECT_FALSE(no_lidar.solved);
  SessionObservations lidar_only = r->obs;
  lidar_only.camera.clear();
  EXPECT_EQ(Calibrate(r->config, lidar_only, r->projection, testing::ShortSessionEngine()).reason,
            Reason::kNoCameraBoards);
}

}  // namespace
}  // namespace calibd
