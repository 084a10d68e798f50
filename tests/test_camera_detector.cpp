// CameraDetector (paper §III-B): PnP recovers known poses for both distortion models, simulated
// frames give every board with sub-pixel corners, ROI tracking agrees with full-frame search, bad
// inputs and configs are handled, and a checkerboard gives its pose.

#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/camera/camera_pnp.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/stopwatch.hpp"
#include "session.hpp"

namespace calibd {
namespace {

ImageView View(const cv::Mat& m) {
  ImageView v;
  v.data = m.data;
  v.width = m.cols;
  v.height = m.rows;
  v.stride = static_cast<int>(m.step[0]);
  return v;
}

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double Max(const std::vector<double>& v) {
  return v.empty() ? 0.0 : *std::max_element(v.begin(), v.end());
}

// A board 10 m ahead, yawed 20 deg and pitched 10 deg, off-centre: T_camera_board. Board frame:
// x right, y up, z towards the viewer (docs/conventions.md#frames), so facing the camera means
// z_B ~ -z_C.
Pose KnownPose(double distance) {
  Pose T = Pose::Identity();
  Eigen::Matrix3d R_facing;
  R_facing << 1, 0, 0, 0, -1, 0, 0, 0, -1;  // x_B = x_C, y_B = -y_C (up), z_B = -z_C
  T.linear() = RotationFromRpy(0.17, 0.35, 0.05) * R_facing;
  T.translation() = Eigen::Vector3d(0.8, -0.3, distance);
  return T;
}

CameraIntrinsics KannalaBrandtCamera() {
  CameraIntrinsics k;
  k.model = DistortionModel::kKannalaBrandt;
  k.fx = k.fy = 1400.0;
  k.k1 = 0.05;
  k.k2 = -0.01;
  k.k3 = 0.002;
  k.k4 = -0.0005;
  k.p1 = k.p2 = 0.0;
  return k;
}

// ---- PnP on synthetic corners ----

TEST(CameraDetectorPnp, RecoversKnownPoseExactlyForBothDistortionModels) {
  BoardGeometry board;
  board.tag_offset_m = {0.03, -0.02};  // the tag off the board centre exercises T_tag_board
  board.tag_size_m = 0.4;
  for (const CameraIntrinsics& k : {CameraIntrinsics{}, KannalaBrandtCamera()}) {
    const CameraModel model(k);
    for (double distance : {3.0, 10.0, 30.0}) {
      const Pose T_true = KnownPose(distance);
      std::array<Eigen::Vector2d, 4> corners;
      for (size_t i = 0; i < 4; ++i)
        ASSERT_TRUE(model.Project(T_true * board.TagCornersInBoard()[i], &corners[i]));
      Pose T_est;
      double rms = -1.0;
      ASSERT_TRUE(EstimateTagPose(model, board, corners, &T_est, &rms));
      EXPECT_LT((T_est.translation() - T_true.translation()).norm(), 1e-6) << distance;
      EXPECT_LT(RotationAngle(T_est.linear(), T_true.linear()), 1e-6) << distance;
      EXPECT_LT(rms, 1e-6);
    }
  }
}

TEST(CameraDetectorPnp, StaysCloseWithPointTwoPixelNoise) {
  const BoardGeometry board;  // 0.48 m tag
  std::mt19937 rng(7);
  std::normal_distribution<double> noise(0.0, 0.2);
  for (const CameraIntrinsics& k : {CameraIntrinsics{}, KannalaBrandtCamera()}) {
    const CameraModel model(k);
    // The same tag sizes in pixels for both cameras (the fisheye has a shorter focal length).
    const double scale = k.fx / 3325.0;
    for (double distance : {6.0 * scale, 15.0 * scale}) {
      const Pose T_true = KnownPose(distance);
      std::vector<double> trans, rot;
      for (int trial = 0; trial < 50; ++trial) {
        std::array<Eigen::Vector2d, 4> corners;
        for (size_t i = 0; i < 4; ++i) {
          ASSERT_TRUE(model.Project(T_true * board.TagCornersInBoard()[i], &corners[i]));
          corners[i] += Eigen::Vector2d(noise(rng), noise(rng));
        }
        Pose T_est;
        double rms = 0.0;
        ASSERT_TRUE(EstimateTagPose(model, board, corners, &T_est, &rms));
        trans.push_back((T_est.translation() - T_true.translation()).norm());
        rot.push_back(RotationAngle(T_est.linear(), T_true.linear()) * kRad2Deg);
      }
      std::printf(
          "[ pnp      ] %s %.0f m, 0.2 px noise: translation median %.4f max %.4f m, "
          "rotation median %.3f max %.3f deg\n",
          k.model == DistortionModel::kRadTan ? "radtan" : "kannala-brandt", distance,
          Median(trans), Max(trans), Median(rot), Max(rot));
      // Four corners of one tag: depth is the weak direction (about distance * noise / size).
      EXPECT_LT(Median(trans), 0.004 * distance) << distance;
      EXPECT_LT(Max(trans), 0.015 * distance) << distance;
      EXPECT_LT(Median(rot), 1.0) << distance;
    }
  }
}

// ---- Simulated frames ----

struct Errors {
  std::vector<double> corner_px, trans_m, rot_deg;
};

// Compares detections with the simulator's truth; returns the number of truth boards found.
int Score(const sim::SessionSimulator& s, const sim::FrameTruth& truth,
          const CameraDetections& dets, Errors* e) {
  int found = 0;
  for (const auto& det : dets.boards) {
    for (size_t b = 0; b < truth.boards.size(); ++b) {
      if (truth.boards[b].board_id != det.board_id) continue;
      ++found;
      const Pose& T = truth.boards[b].T_camera_board;
      const auto corners_b = s.workshop().geometries[b].TagCornersInBoard();
      for (size_t k = 0; k < 4; ++k) {
        Eigen::Vector2d uv;
        EXPECT_TRUE(s.camera_model().Project(T * corners_b[k], &uv));
        e->corner_px.push_back((det.corners_px[k] - uv).norm());
      }
      e->trans_m.push_back((det.T_camera_board.translation() - T.translation()).norm());
      e->rot_deg.push_back(RotationAngle(det.T_camera_board.linear(), T.linear()) * kRad2Deg);
    }
  }
  return found;
}

sim::SessionOptions SimOptions(const std::string& mode, double distance,
                               const std::string& layout) {
  sim::SessionOptions o;
  o.lidar_model = "m1";  // the cheapest scan: these tests only look at the image
  o.trajectory.mode = mode;
  o.trajectory.static_distance_m = distance;
  o.workshop.layout = layout;
  return o;
}

class CameraDetectorSimTest : public ::testing::Test {
 protected:
  // Detects in `frames` static frames at `distance`; every board must be found with its id.
  void CheckStatic(double distance, const std::string& layout, double max_median_corner_px,
                   double max_trans_frac, double max_rot_deg,
                   CameraDetectorConfig config = CameraDetectorConfig{}) {
    sim::SessionSimulator s;
    std::string error;
    ASSERT_TRUE(s.Init(SimOptions("static", distance, layout), &error)) << error;
    CameraDetector detector(config, s.options().camera, s.workshop().geometries);
    ASSERT_TRUE(detector.ok()) << detector.error();
    Errors e;
    cv::Mat image;
    sim::LidarScan scan;
    sim::FrameTruth truth;
    CameraDetections dets;
    for (int k = 0; k < 2; ++k) {
      s.SimulateFrame(k, &image, &scan, &truth);
      detector.Detect(View(image), &dets);
      int in_view = 0;
      for (const auto& b : truth.boards) in_view += b.tag_in_image ? 1 : 0;
      ASSERT_EQ(in_view, 3) << distance;
      EXPECT_EQ(dets.boards.size(), 3u) << distance << " m " << layout << " frame " << k;
      EXPECT_EQ(Score(s, truth, dets, &e), static_cast<int>(dets.boards.size()));
    }
    std::printf(
        "[ corners  ] %s %.0f m: corner error median %.3f max %.3f px; translation "
        "median %.4f max %.4f m; rotation median %.3f max %.3f deg\n",
        layout.c_str(), distance, Median(e.corner_px), Max(e.corner_px), Median(e.trans_m),
        Max(e.trans_m), Median(e.rot_deg), Max(e.rot_deg));
    EXPECT_LT(Median(e.corner_px), max_median_corner_px) << distance;
    EXPECT_LT(Max(e.trans_m), max_trans_frac * distance) << distance;
    EXPECT_LT(Max(e.rot_deg), max_rot_deg) << distance;
  }
};

TEST_F(CameraDetectorSimTest, FindsAllBoardsAt6m) { CheckStatic(6.0, "spread", 0.3, 0.01, 1.0); }
TEST_F(CameraDetectorSimTest, FindsAllBoardsAt10m) { CheckStatic(10.0, "spread", 0.3, 0.01, 1.5); }
TEST_F(CameraDetectorSimTest, FindsAllBoardsAt15m) { CheckStatic(15.0, "spread", 0.3, 0.015, 2.0); }
TEST_F(CameraDetectorSimTest, FindsAllBoardsAt30m) { CheckStatic(30.0, "spread", 0.5, 0.03, 5.0); }
TEST_F(CameraDetectorSimTest, FindsAllBoardsFacingStraight) {
  CheckStatic(10.0, "line", 0.3, 0.01, 2.0);
}

TEST_F(CameraDetectorSimTest, TrackingAgreesWithFullFrameSearchWhileDriving) {
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(SimOptions("drive", 10.0, "spread"), &error)) << error;
  CameraDetectorConfig tracked_config;
  CameraDetectorConfig full_config;
  full_config.track_rois = false;
  CameraDetector tracked(tracked_config, s.options().camera, s.workshop().geometries);
  CameraDetector full(full_config, s.options().camera, s.workshop().geometries);
  ASSERT_TRUE(tracked.ok()) << tracked.error();
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  CameraDetections a, b;
  std::vector<double> ms_tracked, ms_full, ms_tracked_full_frames, diff;
  Errors e;
  int tracked_frames = 0;
  for (int k = 0; k < 30; ++k) {
    s.SimulateFrame(k, &image, &scan, &truth);
    auto t0 = std::chrono::steady_clock::now();
    tracked.Detect(View(image), &a, truth.camera_utime);
    auto t1 = std::chrono::steady_clock::now();
    full.Detect(View(image), &b);
    auto t2 = std::chrono::steady_clock::now();
    const double ta = MsBetween(t0, t1);
    (a.full_frame_search ? ms_tracked_full_frames : ms_tracked).push_back(ta);
    ms_full.push_back(MsBetween(t1, t2));
    tracked_frames += a.full_frame_search ? 0 : 1;
    ASSERT_EQ(a.boards.size(), b.boards.size()) << "frame " << k;
    for (const auto& da : a.boards) {
      const auto it =
          std::find_if(b.boards.begin(), b.boards.end(),
                       [&](const BoardDetection2D& d) { return d.board_id == da.board_id; });
      ASSERT_NE(it, b.boards.end()) << "frame " << k << " board " << da.board_id;
      for (size_t c = 0; c < 4; ++c) diff.push_back((da.corners_px[c] - it->corners_px[c]).norm());
    }
    Score(s, truth, a, &e);
  }
  std::printf(
      "[ tracking ] 30 driving frames: %d tracked; corner difference tracked vs full "
      "median %.4f max %.4f px; corner error vs truth median %.3f max %.3f px\n",
      tracked_frames, Median(diff), Max(diff), Median(e.corner_px), Max(e.corner_px));
  std::printf(
      "[ timing   ] tracked frames median %.1f ms (max %.1f); full-frame frames of the "
      "tracker median %.1f ms; full-frame detector median %.1f ms (max %.1f)\n",
      Median(ms_tracked), Max(ms_tracked), Median(ms_tracked_full_frames), Median(ms_full),
      Max(ms_full));
  EXPECT_GT(tracked_frames, 20);
  // AprilTag's refined corners depend on the window it searched (its threshold tiles and the
  // decimation differ between a crop and the full frame): measured median 0.05, max 0.22 px
  // apart, both as close to the truth. The truth is what matters to calibration.
  EXPECT_LT(Median(diff), 0.1);
  EXPECT_LT(Max(diff), 0.3);
  EXPECT_LT(Median(e.corner_px), 0.3);
}

// Detectors of one image with other intrinsics and tag sizes take AprilTag's searches of the
// windows another left in a TagSearchMemo: their detections are those they find alone, exactly.
TEST_F(CameraDetectorSimTest, DetectorsSharingTheSearchesOfAnImageDetectAsAlone) {
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(SimOptions("drive", 10.0, "spread"), &error)) << error;
  CameraIntrinsics longer = s.options().camera;
  longer.fx *= 1.02;
  longer.fy *= 1.02;
  std::vector<BoardGeometry> smaller = s.workshop().geometries;
  for (BoardGeometry& g : smaller) g.tag_size_m *= 0.97;
  CameraDetector first({}, s.options().camera, s.workshop().geometries);
  CameraDetector shared({}, longer, smaller), alone({}, longer, smaller);
  ASSERT_TRUE(first.ok() && shared.ok() && alone.ok());
  TagSearchMemo memo;
  first.UseSearchMemo(&memo);
  shared.UseSearchMemo(&memo);
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  CameraDetections a, b, c;
  int boards = 0;
  for (int k = 0; k < 20; ++k) {
    s.SimulateFrame(k, &image, &scan, &truth);
    memo.Clear();
    first.Detect(View(image), &a, truth.camera_utime);
    shared.Detect(View(image), &b, truth.camera_utime);
    alone.Detect(View(image), &c, truth.camera_utime);
    ASSERT_EQ(b.boards.size(), c.boards.size()) << "frame " << k;
    EXPECT_EQ(b.full_frame_search, c.full_frame_search) << "frame " << k;
    EXPECT_EQ(b.rejected, c.rejected) << "frame " << k;
    for (size_t i = 0; i < b.boards.size(); ++i) {
      EXPECT_EQ(b.boards[i].board_id, c.boards[i].board_id);
      for (size_t j = 0; j < 4; ++j)
        EXPECT_EQ(b.boards[i].corners_px[j], c.boards[i].corners_px[j]);
      EXPECT_EQ(b.boards[i].T_camera_board.matrix(), c.boards[i].T_camera_board.matrix());
    }
    boards += static_cast<int>(b.boards.size());
  }
  EXPECT_GT(boards, 20);
  EXPECT_GE(memo.reused(), 20) << "the second detector's searches came from the memo";
}

// The search policy (CameraDetectorConfig::track_rois): with every configured board tracked, no
// full-frame search after the first unless full_frame_every asks for them.
TEST_F(CameraDetectorSimTest, SearchesTheFullFrameOnlyWhenABoardIsMissing) {
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(SimOptions("static", 10.0, "spread"), &error)) << error;
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  s.SimulateFrame(0, &image, &scan, &truth);
  for (int every : {0, 5}) {
    CameraDetectorConfig config;
    config.full_frame_every = every;
    CameraDetector detector(config, s.options().camera, s.workshop().geometries);
    ASSERT_TRUE(detector.ok()) << detector.error();
    CameraDetections out;
    std::vector<int> full_frames;
    for (int k = 0; k < 12; ++k) {
      detector.Detect(View(image), &out, int64_t{100000} * k);  // a 10 Hz stream
      EXPECT_EQ(out.boards.size(), 3u) << "frame " << k;
      if (out.full_frame_search) full_frames.push_back(k);
    }
    EXPECT_EQ(full_frames, every == 0 ? std::vector<int>{0} : std::vector<int>({0, 5, 10}))
        << "full_frame_every " << every;
  }
  // Not a stream: frames 2 s apart (still poses) or without capture times are each searched
  // whole, and every board is found in each.
  for (const int64_t step_us : {int64_t{2000000}, int64_t{0}}) {
    CameraDetector detector(CameraDetectorConfig{}, s.options().camera, s.workshop().geometries);
    CameraDetections out;
    for (int k = 0; k < 4; ++k) {
      detector.Detect(View(image), &out, step_us > 0 ? step_us * k : kUnknownCaptureTime);
      EXPECT_TRUE(out.full_frame_search) << "frame " << k << ", step " << step_us << " us";
      EXPECT_EQ(out.boards.size(), 3u);
    }
  }
  // A board out of view (its tag blanked): the others are tracked, and the full frame is searched
  // again every missing_search_every frames to find it.
  const BoardDetection2D first = [&] {
    CameraDetector d(CameraDetectorConfig{}, s.options().camera, s.workshop().geometries);
    CameraDetections out;
    d.Detect(View(image), &out);
    return out.boards.front();
  }();
  cv::Mat hidden = image.clone();
  std::vector<cv::Point> quad;
  for (const auto& c : first.corners_px)
    quad.emplace_back(static_cast<int>(c.x()), static_cast<int>(c.y()));
  cv::Rect box = cv::boundingRect(quad);
  box.x -= box.width / 2;
  box.y -= box.height / 2;
  box.width *= 2;
  box.height *= 2;
  hidden(box & cv::Rect(0, 0, hidden.cols, hidden.rows)).setTo(128);
  CameraDetector detector(CameraDetectorConfig{}, s.options().camera, s.workshop().geometries);
  CameraDetections out;
  std::vector<int> full_frames;
  for (int k = 0; k < 10; ++k) {
    detector.Detect(View(hidden), &out, int64_t{100000} * k);
    EXPECT_EQ(out.boards.size(), 2u) << "frame " << k;
    if (out.full_frame_search) full_frames.push_back(k);
  }
  EXPECT_EQ(full_frames, std::vector<int>({0, 3, 6, 9}));
}

// ---- Inputs without boards, bad configs ----

TEST(CameraDetector, EmptyImagesAndFramesWithoutBoardsGiveEmptyResults) {
  std::vector<BoardGeometry> boards(3);
  for (int i = 0; i < 3; ++i)
    boards[static_cast<size_t>(i)].board_id = boards[static_cast<size_t>(i)].tag_id = i;
  CameraDetector detector(CameraDetectorConfig{}, CameraIntrinsics{}, boards);
  ASSERT_TRUE(detector.ok()) << detector.error();
  CameraDetections dets;
  dets.boards.resize(2);  // stale content must be cleared
  detector.Detect(ImageView{}, &dets);
  EXPECT_TRUE(dets.boards.empty());
  const cv::Mat empty;
  detector.Detect(View(empty), &dets);
  EXPECT_TRUE(dets.boards.empty());
  const cv::Mat grey(1920, 3840, CV_8UC1, cv::Scalar(128));
  detector.Detect(View(grey), &dets);
  EXPECT_TRUE(dets.boards.empty());
  EXPECT_EQ(dets.rejected, 0);
}

TEST(CameraDetector, TagsWithUnconfiguredIdsAreNotReported) {
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(SimOptions("static", 8.0, "spread"), &error)) << error;
  std::vector<BoardGeometry> boards = s.workshop().geometries;
  for (auto& b : boards) b.tag_id += 10;  // the simulator prints ids 0, 1, 2
  CameraDetector detector(CameraDetectorConfig{}, s.options().camera, boards);
  ASSERT_TRUE(detector.ok()) << detector.error();
  cv::Mat image;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  s.SimulateFrame(0, &image, &scan, &truth);
  CameraDetections dets;
  detector.Detect(View(image), &dets);
  EXPECT_TRUE(dets.boards.empty());
  EXPECT_GE(dets.rejected, 3);
}

TEST(CameraDetector, BadConfigNamesTheField) {
  const std::vector<BoardGeometry> boards(1);
  {
    CameraDetectorConfig c;
    c.quad_decimate = 0.0f;
    CameraDetector d(c, CameraIntrinsics{}, boards);
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error().find("quad_decimate"), std::string::npos) << d.error();
  }
  {
    std::vector<BoardGeometry> b = boards;
    b[0].tag_family = "tag99h99";
    CameraDetector d(CameraDetectorConfig{}, CameraIntrinsics{}, b);
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error().find("tag_family"), std::string::npos) << d.error();
  }
  {
    std::vector<BoardGeometry> b(2);
    b[1].board_id = b[1].tag_id = 1;
    b[1].tag_family = "tag25h9";
    CameraDetector d(CameraDetectorConfig{}, CameraIntrinsics{}, b);
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error().find("tag_family"), std::string::npos) << d.error();
  }
  {
    CameraIntrinsics k;
    k.fx = -1.0;
    CameraDetector d(CameraDetectorConfig{}, k, boards);
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error().find("fx"), std::string::npos) << d.error();
  }
  {
    CameraDetectorConfig c;
    c.full_frame_every = -1;
    CameraDetector d(c, CameraIntrinsics{}, boards);
    EXPECT_FALSE(d.ok());
    EXPECT_NE(d.error().find("full_frame_every"), std::string::npos) << d.error();
  }
  // Every supported family builds a detector.
  for (const char* family :
       {"tag36h11", "tag36h10", "tag25h9", "tag16h5", "tagStandard41h12", "tagCircle21h7"}) {
    std::vector<BoardGeometry> b = boards;
    b[0].tag_family = family;
    CameraDetector d(CameraDetectorConfig{}, CameraIntrinsics{}, b);
    EXPECT_TRUE(d.ok()) << family << ": " << d.error();
  }
}

// ---- Checkerboard ----

// Renders a checkerboard board seen by `model` at T_camera_board: each pixel's ray (through the
// distortion) meets the board plane, and the print is sampled there with 4x4 supersampling.
cv::Mat RenderCheckerboard(const CameraModel& model, const BoardGeometry& g,
                           const Pose& T_camera_board) {
  const auto& k = model.intrinsics();
  cv::Mat image(k.height, k.width, CV_8UC1, cv::Scalar(90));
  const Pose T_board_camera = T_camera_board.inverse();
  const double s = g.checker_square_size_m;
  const double half_w = (g.checker_inner_cols + 1) * s / 2.0;
  const double half_h = (g.checker_inner_rows + 1) * s / 2.0;
  auto shade = [&](const Eigen::Vector2d& xy) -> double {
    const Eigen::Vector3d o = T_board_camera.translation();
    const Eigen::Vector3d d = T_board_camera.linear() * Eigen::Vector3d(xy.x(), xy.y(), 1.0);
    if (std::abs(d.z()) < 1e-12) return 90.0;
    const double t = -o.z() / d.z();
    if (t <= 0.0) return 90.0;
    const Eigen::Vector3d p = o + t * d;
    if (std::abs(p.x()) > g.width_m / 2 || std::abs(p.y()) > g.height_m / 2) return 90.0;
    const double x = p.x() - g.tag_offset_m.x(), y = p.y() - g.tag_offset_m.y();
    if (std::abs(x) > half_w || std::abs(y) > half_h) return 220.0;  // white margin
    // Square (i, j) from the top-left; the top-left square is black.
    const int i = static_cast<int>(std::floor((half_h - y) / s));
    const int j = static_cast<int>(std::floor((x + half_w) / s));
    return ((i + j) % 2 == 0) ? 25.0 : 220.0;
  };
  // Only the board's bounding box needs the ray cast.
  double umin = 1e9, umax = -1e9, vmin = 1e9, vmax = -1e9;
  for (const auto& v : g.BoardVerticesInBoard()) {
    Eigen::Vector2d uv;
    model.Project(T_camera_board * v, &uv, 1e6);
    umin = std::min(umin, uv.x());
    umax = std::max(umax, uv.x());
    vmin = std::min(vmin, uv.y());
    vmax = std::max(vmax, uv.y());
  }
  for (int v = std::max(0, static_cast<int>(vmin) - 2);
       v < std::min(k.height, static_cast<int>(vmax) + 3); ++v) {
    for (int u = std::max(0, static_cast<int>(umin) - 2);
         u < std::min(k.width, static_cast<int>(umax) + 3); ++u) {
      double sum = 0.0;
      for (int a = 0; a < 4; ++a) {
        for (int b = 0; b < 4; ++b) {
          Eigen::Vector2d xy;
          model.Unproject({u - 0.375 + 0.25 * b, v - 0.375 + 0.25 * a}, &xy);
          sum += shade(xy);
        }
      }
      image.at<uint8_t>(v, u) = static_cast<uint8_t>(std::lround(sum / 16.0));
    }
  }
  cv::GaussianBlur(image, image, cv::Size(0, 0), 0.6);
  cv::Mat noise(image.size(), CV_8SC1);
  cv::randn(noise, 0, 2);
  cv::add(image, noise, image, cv::noArray(), CV_8UC1);
  return image;
}

// A half-size camera with the default one's field of view: keeps the rendering quick.
CameraIntrinsics HalfSizeCamera() {
  CameraIntrinsics k;
  k.width = 1920;
  k.height = 960;
  k.fx = k.fy = 1662.5;
  k.cx = 959.5;
  k.cy = 479.5;
  return k;
}

// Board 7: a checkerboard of 5 x 7 inner corners, 6 cm squares.
BoardGeometry SmallCheckerboard() {
  BoardGeometry g;
  g.board_id = 7;
  g.pattern = BoardGeometry::PatternKind::kCheckerboard;
  g.checker_inner_rows = 5;
  g.checker_inner_cols = 7;
  g.checker_square_size_m = 0.06;
  return g;
}

TEST(CameraDetector, CheckerboardGivesItsPose) {
  const CameraIntrinsics k = HalfSizeCamera();
  const CameraModel model(k);
  const BoardGeometry g = SmallCheckerboard();
  std::string error;
  ASSERT_TRUE(g.IsValid(&error)) << error;
  ASSERT_EQ(g.CheckerCornersInBoard().size(), 35u);

  for (double distance : {2.5, 4.0}) {
    Pose T_true = KnownPose(distance);
    T_true.translation().x() = 0.3;
    const cv::Mat image = RenderCheckerboard(model, g, T_true);
    CameraDetector detector(CameraDetectorConfig{}, k, {g});
    ASSERT_TRUE(detector.ok()) << detector.error();
    CameraDetections dets;
    const auto t0 = std::chrono::steady_clock::now();
    detector.Detect(View(image), &dets);
    const double ms = MsSince(t0);
    ASSERT_EQ(dets.boards.size(), 1u) << distance;
    const BoardDetection2D& det = dets.boards[0];
    EXPECT_EQ(det.board_id, 7);
    const double trans = (det.T_camera_board.translation() - T_true.translation()).norm();
    const double rot = RotationAngle(det.T_camera_board.linear(), T_true.linear()) * kRad2Deg;
    double worst_corner = 0.0;
    for (size_t c = 0; c < 4; ++c) {
      Eigen::Vector2d uv;
      ASSERT_TRUE(model.Project(T_true * g.TagCornersInBoard()[c], &uv));
      worst_corner = std::max(worst_corner, (det.corners_px[c] - uv).norm());
    }
    std::printf(
        "[ checker  ] %.1f m: translation error %.4f m, rotation %.3f deg, outer corners "
        "max %.3f px, rms %.3f px, %.1f ms\n",
        distance, trans, rot, worst_corner, det.reprojection_rms_px, ms);
    EXPECT_LT(trans, 0.005 * distance);
    EXPECT_LT(rot, 0.5);
    EXPECT_LT(worst_corner, 0.5);  // the right corners, in the right order
  }
}

TEST(CameraDetector, ASmallCheckerboardInAStillFrameIsSearchedAtFullResolution) {
  // Squares of 7 px: gone in the half-size image the search runs on, found at full resolution,
  // which a still frame (no stream) can afford; a frame of a 10 Hz stream does not pay for it.
  const CameraIntrinsics k = HalfSizeCamera();
  const CameraModel model(k);
  const BoardGeometry g = SmallCheckerboard();
  const double distance = 14.0;
  Pose T_true = KnownPose(distance);
  T_true.translation().x() = 0.3;
  const cv::Mat image = RenderCheckerboard(model, g, T_true);

  CameraDetector still(CameraDetectorConfig{}, k, {g});
  CameraDetections dets;
  still.Detect(View(image), &dets);  // no capture time: a still
  ASSERT_EQ(dets.boards.size(), 1u);
  EXPECT_LT((dets.boards[0].T_camera_board.translation() - T_true.translation()).norm(),
            0.01 * distance);

  CameraDetector stream(CameraDetectorConfig{}, k, {g});
  stream.Detect(View(image), &dets, 1000000);
  stream.Detect(View(image), &dets, 1100000);  // 0.1 s later: a stream
  EXPECT_TRUE(dets.boards.empty());
}

TEST(CameraDetector, CheckerboardGeometryIsValidated) {
  BoardGeometry g;
  g.pattern = BoardGeometry::PatternKind::kCheckerboard;
  std::string error;
  EXPECT_TRUE(g.IsValid(&error)) << error;
  g.checker_inner_rows = 1;
  EXPECT_FALSE(g.IsValid(&error));
  EXPECT_NE(error.find("checker_inner_rows"), std::string::npos) << error;
  g.checker_inner_rows = 5;
  g.checker_square_size_m = 0.2;  // 8 x 6 squares of 0.2 m do not fit on 0.6 m
  EXPECT_FALSE(g.IsValid(&error));
  EXPECT_NE(error.find("fit"), std::string::npos) << error;
  // Row-major from the top-left inner corner: y decreases down the rows, x grows along a row.
  g.checker_square_size_m = 0.06;
  const auto pts = g.CheckerCornersInBoard();
  EXPECT_NEAR(pts.front().x(), -0.18, 1e-12);
  EXPECT_NEAR(pts.front().y(), 0.12, 1e-12);
  EXPECT_NEAR(pts.back().x(), 0.18, 1e-12);
  EXPECT_NEAR(pts.back().y(), -0.12, 1e-12);
  EXPECT_TRUE(g.TagCornersInBoard()[0].isApprox(pts[28]));  // bottom-left
}

}  // namespace
}  // namespace calibd
