// LidarDetector (paper §III-C) end to end on simulated sweeps: precision/recall against the
// simulator's truth, candidates for the hard negatives, empty and broken inputs, bad configs and
// fixed memory.

#include "calibd/core/lidar/lidar_detector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/stats.hpp"
#include "calibd/core/lidar/board_references.hpp"
#include "lidar_sim.hpp"
#include "scene.hpp"
#include "session.hpp"
#include "small_camera.hpp"

namespace calibd {
namespace {

PointCloudView ViewOf(const sim::LidarScan& scan) {
  PointCloudView v;
  v.x = scan.x.data();
  v.y = scan.y.data();
  v.z = scan.z.data();
  v.ring = scan.ring.data();
  v.size = scan.size();
  return v;
}

sim::SessionOptions Session(const std::string& lidar, const std::string& trajectory,
                            uint64_t seed) {
  sim::SessionOptions o;
  o.seed = seed;
  o.lidar_model = lidar;
  o.trajectory.mode = trajectory;
  o.camera = testing::SmallCamera();
  return o;
}

// Board centres in the LiDAR frame at the camera time, from the truth.
std::vector<Eigen::Vector3d> TrueCentres(const sim::SessionSimulator& s, const sim::FrameTruth& t) {
  const Pose T_lidar_world = (t.T_world_vehicle * s.T_vehicle_lidar()).inverse();
  std::vector<Eigen::Vector3d> out;
  for (const auto& b : s.workshop().scene.boards)
    out.push_back(T_lidar_world * b.T_world_board.translation());
  return out;
}

struct Tally {
  int tp = 0, fp = 0, fn = 0;
  double precision() const { return tp + fp > 0 ? double(tp) / (tp + fp) : 1.0; }
  double recall() const { return tp + fn > 0 ? double(tp) / (tp + fn) : 1.0; }
};

int EnvInt(const char* name, int fallback) {
  const char* v = std::getenv(name);
  return v ? std::atoi(v) : fallback;
}

// Scores a detector over `frames` frames of a session. A detection is a true positive when its
// centroid is within 0.2 m of a true board centre; a board with at least `min_truth_points` LiDAR
// points that no detection matches is a false negative.
Tally Evaluate(const std::string& lidar, const std::string& trajectory, int frames,
               int min_truth_points, LidarStageTimes* mean_times, bool verbose) {
  sim::SessionSimulator s;
  std::string error;
  EXPECT_TRUE(s.Init(Session(lidar, trajectory, 7), &error)) << error;
  LidarDetector detector(LidarDetectorConfig{}, s.lidar_model(), s.workshop().geometries);
  EXPECT_TRUE(detector.ok()) << detector.error();
  Tally tally;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  LidarDetections out;
  *mean_times = LidarStageTimes{};
  const int step = std::max(1, s.num_frames() / frames);
  int used = 0;
  for (int k = 0; k < s.num_frames() && used < frames; k += step, ++used) {
    s.SimulateFrame(k, nullptr, &scan, &truth);
    detector.Detect(ViewOf(scan), &out);
    mean_times->range_image_ms += out.times.range_image_ms / frames;
    mean_times->ground_ms += out.times.ground_ms / frames;
    mean_times->segmentation_ms += out.times.segmentation_ms / frames;
    mean_times->descriptor_ms += out.times.descriptor_ms / frames;
    mean_times->total_ms += out.times.total_ms / frames;
    const std::vector<Eigen::Vector3d> centres = TrueCentres(s, truth);
    std::vector<bool> found(centres.size(), false);
    for (const BoardCluster& b : out.boards) {
      bool tp = false;
      for (size_t i = 0; i < centres.size(); ++i) {
        if ((b.centroid - centres[i]).norm() < 0.2) {
          tp = true;
          found[i] = true;
        }
      }
      tally.tp += tp ? 1 : 0;
      tally.fp += tp ? 0 : 1;
      if (!tp && verbose) {
        std::cout << lidar << " frame " << k << " FP at " << b.centroid.transpose() << " score "
                  << b.score << " n " << b.cluster_points;
        for (const LidarCandidate& c : out.candidates)
          if ((c.centroid - b.centroid).norm() < 1e-9)
            std::cout << " extents " << c.extents.transpose() << " planarity " << c.planarity;
        std::cout << "\n";
      }
    }
    if (std::getenv("CALIBD_LIDAR_EVAL_CSV")) {
      for (const LidarCandidate& c : out.candidates) {
        int board = -1;
        for (size_t i = 0; i < centres.size(); ++i)
          if ((c.centroid - centres[i]).norm() < 0.2) board = static_cast<int>(i);
        std::cout << "CSV," << lidar << "," << k << "," << board << "," << c.score << ","
                  << c.num_points << "," << c.centroid.norm() << "," << c.extents(0) << ","
                  << c.extents(1) << "," << c.extents(2) << "," << c.planarity << ","
                  << std::sqrt(c.eigenvalues(0) + c.eigenvalues(1)) << ","
                  << std::sqrt(c.eigenvalues(2)) << "\n";
      }
    }
    for (size_t i = 0; i < centres.size(); ++i) {
      const int n = static_cast<int>(truth.boards[i].lidar_point_indices.size());
      if (found[i] || n < min_truth_points) continue;
      ++tally.fn;
      if (verbose) {
        std::cout << lidar << " frame " << k << " FN board " << i << " at "
                  << centres[i].transpose() << " truth points " << n;
        for (const LidarCandidate& c : out.candidates)
          if ((c.centroid - centres[i]).norm() < 0.3)
            std::cout << " | cand score " << c.score << " n " << c.num_points << " extents "
                      << c.extents.transpose() << " planarity " << c.planarity;
        std::cout << "\n";
      }
    }
  }
  return tally;
}

struct Fixture {
  sim::SessionSimulator session;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  explicit Fixture(const std::string& lidar, const std::string& trajectory = "static") {
    std::string error;
    sim::SessionOptions o = Session(lidar, trajectory, 3);
    o.trajectory.static_distance_m = 10.0;
    EXPECT_TRUE(session.Init(o, &error)) << error;
    session.SimulateFrame(0, nullptr, &scan, &truth);
  }
};

TEST(LidarDetectorTest, AFrameWithoutBoardsGivesAnEmptyResultAndNanPointsAreSkipped) {
  Fixture f("ot128");
  LidarDetector detector(LidarDetectorConfig{}, f.session.lidar_model(),
                         f.session.workshop().geometries);
  ASSERT_TRUE(detector.ok()) << detector.error();
  LidarDetections out;
  detector.Detect(ViewOf(f.scan), &out);
  EXPECT_EQ(out.boards.size(), 3u);
  // Remove the boards' returns (as dropped returns: NaN and inf) and their stands stay behind.
  int removed = 0;
  for (size_t i = 0; i < f.scan.size(); ++i) {
    if (f.scan.board[i] < 0) continue;
    f.scan.x[i] = (removed % 2) ? std::numeric_limits<float>::quiet_NaN()
                                : std::numeric_limits<float>::infinity();
    ++removed;
  }
  detector.Detect(ViewOf(f.scan), &out);
  EXPECT_TRUE(out.boards.empty());
  EXPECT_GE(out.invalid_points, removed);
  for (const LidarCandidate& c : out.candidates) EXPECT_LT(c.score, 1.0);
}

TEST(LidarDetectorTest, EmptyAndAllInvalidCloudsGiveEmptyResults) {
  const LidarModel model = MakeLidarModel(LidarKind::kM1);
  LidarDetector detector(LidarDetectorConfig{}, model, {BoardGeometry{}});
  ASSERT_TRUE(detector.ok()) << detector.error();
  LidarDetections out;
  detector.Detect(PointCloudView{}, &out);
  EXPECT_TRUE(out.boards.empty());
  EXPECT_TRUE(out.candidates.empty());
  EXPECT_EQ(out.invalid_points, 0);
  const float nan = std::numeric_limits<float>::quiet_NaN();
  std::vector<float> x(100, nan), y(100, 1.0f), z(100, 0.0f);
  PointCloudView view{x.data(), y.data(), z.data(), nullptr, x.size()};
  detector.Detect(view, &out);
  EXPECT_TRUE(out.boards.empty());
  EXPECT_EQ(out.invalid_points, 100);
}

TEST(LidarDetectorTest, BadConfigIsRejectedNamingTheField) {
  const LidarModel model = MakeLidarModel(LidarKind::kOt128);
  auto error_of = [&](const LidarDetectorConfig& c, std::vector<BoardGeometry> boards) {
    LidarDetector d(c, model, boards);
    EXPECT_FALSE(d.ok());
    LidarDetections out;
    d.Detect(PointCloudView{}, &out);  // a detector that is not ok does nothing, safely
    return d.error();
  };
  LidarDetectorConfig c;
  c.segmentation_angle_deg = 0.0;
  EXPECT_NE(error_of(c, {BoardGeometry{}}).find("segmentation_angle_deg"), std::string::npos);
  c = LidarDetectorConfig{};
  c.match_threshold = 1.5;
  EXPECT_NE(error_of(c, {BoardGeometry{}}).find("match_threshold"), std::string::npos);
  c = LidarDetectorConfig{};
  c.max_range_m = 0.5;
  EXPECT_NE(error_of(c, {BoardGeometry{}}).find("max_range_m"), std::string::npos);
  c = LidarDetectorConfig{};
  c.min_cluster_points = 1;
  EXPECT_NE(error_of(c, {BoardGeometry{}}).find("min_cluster_points"), std::string::npos);
  EXPECT_NE(error_of(LidarDetectorConfig{}, {}).find("boards"), std::string::npos);
  std::string e;
  EXPECT_TRUE(LidarDetectorConfig{}.IsValid(&e)) << e;
}

TEST(LidarDetectorTest, DetectAllocatesNothingOnceTheOutputHasBeenUsed) {
  Fixture f("falcon");
  LidarDetector detector(LidarDetectorConfig{}, f.session.lidar_model(),
                         f.session.workshop().geometries);
  ASSERT_TRUE(detector.ok()) << detector.error();
  LidarDetections out;
  detector.Detect(ViewOf(f.scan), &out);
  ASSERT_FALSE(out.boards.empty());
  const void* data[4] = {out.boards.data(), out.points.data(), out.point_indices.data(),
                         out.candidates.data()};
  const size_t cap[4] = {out.boards.capacity(), out.points.capacity(), out.point_indices.capacity(),
                         out.candidates.capacity()};
  f.session.SimulateFrame(5, nullptr, &f.scan, &f.truth);
  detector.Detect(ViewOf(f.scan), &out);
  ASSERT_FALSE(out.boards.empty());
  EXPECT_EQ(data[0], out.boards.data());
  EXPECT_EQ(data[1], out.points.data());
  EXPECT_EQ(data[2], out.point_indices.data());
  EXPECT_EQ(data[3], out.candidates.data());
  EXPECT_EQ(cap[0], out.boards.capacity());
  EXPECT_EQ(cap[1], out.points.capacity());
  EXPECT_EQ(cap[2], out.point_indices.capacity());
  EXPECT_EQ(cap[3], out.candidates.capacity());
  // The stored points are the input points of the board clusters: board returns, apart from a
  // few mixed points at the edges.
  for (const BoardCluster& b : out.boards) {
    EXPECT_GT(b.num_points, 20);
    EXPECT_GT(b.normal.dot(-b.centroid), 0.0);  // faces the sensor
    int on_board = 0;
    for (int k = b.first_point; k < b.first_point + b.num_points; ++k) {
      const int i = out.point_indices[k];
      EXPECT_EQ(out.points[k].x(), f.scan.x[i]);
      on_board += f.scan.board[i] >= 0 ? 1 : 0;
    }
    EXPECT_GE(on_board, 0.95 * b.num_points);
  }
}

// Synthetic clusters: range noise along the beam, 2 cm like the simulator's.
std::vector<Eigen::Vector3f> Noisy(std::vector<Eigen::Vector3f> p, uint32_t seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<float> n(0.0f, 0.02f);
  for (Eigen::Vector3f& q : p) q *= 1.0f + n(rng) / q.norm();
  return p;
}

// Points of a w x h rectangle (vertical, facing the sensor, centre at distance d) on a grid.
std::vector<Eigen::Vector3f> Rectangle(double w, double h, double d, double step) {
  std::vector<Eigen::Vector3f> p;
  for (double u = -w / 2; u <= w / 2; u += step)
    for (double v = -h / 2; v <= h / 2; v += step)
      p.emplace_back(static_cast<float>(d), static_cast<float>(u), static_cast<float>(v));
  return p;
}

// A daemon stopping during its start-up stops the reference build (FrameIntake's destructor):
// a cancelled detector is not ok and says why; the checks that cost nothing still name a bad
// input without any build.
TEST(LidarDetectorTest, ACancelledReferenceBuildLeavesADetectorThatIsNotOk) {
  const LidarModel model = MakeLidarModel(LidarKind::kM1);
  const std::atomic<bool> cancel{true};
  LidarDetector detector(LidarDetectorConfig{}, model, {BoardGeometry{}}, &cancel);
  EXPECT_FALSE(detector.ok());
  EXPECT_NE(detector.error().find("cancelled"), std::string::npos) << detector.error();
  EXPECT_EQ(detector.num_references(), 0);
  std::string error;
  EXPECT_TRUE(LidarDetector::CheckInputs(LidarDetectorConfig{}, model, {BoardGeometry{}}, &error));
  EXPECT_FALSE(LidarDetector::CheckInputs(LidarDetectorConfig{}, model, {}, &error));
  EXPECT_EQ(error, "boards: at least one board is needed");
}

TEST(LidarDetectorTest, BoardDescriptorScoresHigherThanWallsPolesBoxesAndTheDoorPanel) {
  const LidarModel model = MakeLidarModel(LidarKind::kOt128);
  LidarDetector detector(LidarDetectorConfig{}, model, {BoardGeometry{}});
  ASSERT_TRUE(detector.ok()) << detector.error();
  EXPECT_GT(detector.num_references(), 100);
  std::vector<Eigen::Vector3f> board;
  SimulateBoardCluster(model, 0.6, 0.6, BoardView{11.0, -4.0, 15.0, 5.0}, &board);
  const double board_score = detector.ScoreCluster(Noisy(board, 1));
  EXPECT_GE(board_score, 0.94);

  std::vector<Eigen::Vector3f> pole, box;
  for (int i = 0; i < 40; ++i)
    for (int k = -4; k <= 4; ++k) {  // the visible half of a 0.15 m radius, 2 m pole
      const double a = k * 0.35;
      pole.emplace_back(static_cast<float>(10.0 - 0.15 * std::cos(a)),
                        static_cast<float>(0.15 * std::sin(a)),
                        static_cast<float>(-1.9 + 0.05 * i));
    }
  for (double u = -0.5; u <= 0.5; u += 0.03)  // a 1 m crate seen on its corner: two faces
    for (double v = -0.5; v <= 0.5; v += 0.03) {
      box.emplace_back(static_cast<float>(9.0 + std::fabs(u)), static_cast<float>(u),
                       static_cast<float>(v));
    }
  const struct {
    const char* name;
    std::vector<Eigen::Vector3f> points;
  } negatives[] = {
      {"wall", Noisy(Rectangle(4.0, 2.5, 12.0, 0.05), 2)},
      {"door panel", Noisy(Rectangle(1.0, 2.1, 10.0, 0.035), 3)},
      {"pole", Noisy(pole, 4)},
      {"box", Noisy(box, 5)},
  };
  for (const auto& n : negatives) {
    const double score = detector.ScoreCluster(n.points);
    std::cout << n.name << " score " << score << " (board " << board_score << ")\n";
    // M2DP alone ranks the board first; flat rectangles still correlate well (0.9+), which is why
    // the size gate runs before it (PrecisionAndRecallOnDrivingSessions: no false positives on
    // the workshop's walls and door panel).
    EXPECT_LT(score, board_score) << n.name;
  }
}

TEST(LidarDetectorTest, NoisyReferencesScoreNoisySimulatedBoardsAtThePapersThreshold) {
  // Boards between the reference views (distance, turn, grid phase) with 2 cm range noise, as a
  // real sweep sees them. The default detector scores them at the paper's 0.94. With He's finer
  // M2DP bins (l = 8, t = 16) the descriptor is sensitive to noise and sampling, and there the
  // averaged noisy references score them clearly higher than single noise-free ones, the paper's
  // Fig. 2b taken literally.
  for (LidarKind kind : {LidarKind::kOt128, LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarModel model = MakeLidarModel(kind);
    LidarDetector detector(LidarDetectorConfig{}, model, {BoardGeometry{}});
    LidarDetectorConfig fine;
    fine.m2dp_rings = 8;
    fine.m2dp_sectors = 16;
    LidarDetector noisy(fine, model, {BoardGeometry{}});
    fine.reference_range_noise_m = 0.0;
    fine.reference_samples = 1;
    LidarDetector clean(fine, model, {BoardGeometry{}});
    ASSERT_TRUE(detector.ok() && noisy.ok() && clean.ok());
    int trials = 0, above = 0;
    double noisy_sum = 0.0, clean_sum = 0.0;
    std::vector<Eigen::Vector3f> board;
    for (double distance : {10.0, 15.0, 22.0, 28.0}) {
      for (int t = 0; t < 5; ++t) {
        BoardView view{distance, -3.0, -25.0 + 12.0 * t, 10.0 - 5.0 * t};
        view.azimuth_phase = 0.37 * t - 0.5;
        view.elevation_phase = 0.23 * t - 0.4;
        SimulateBoardCluster(model, 0.6, 0.6, view, &board);
        AddRangeNoise(0.02, 100 + 10 * trials, &board);
        ++trials;
        above += detector.ScoreCluster(board) >= 0.94 ? 1 : 0;
        noisy_sum += noisy.ScoreCluster(board);
        clean_sum += clean.ScoreCluster(board);
      }
    }
    std::cout << model.name << ": " << above << " of " << trials
              << " boards score >= 0.94; with l = 8, t = 16 mean score " << noisy_sum / trials
              << " against noisy references, " << clean_sum / trials
              << " against noise-free ones\n";
    EXPECT_GE(above, 0.9 * trials) << model.name;
    EXPECT_GT(noisy_sum, clean_sum + 0.01 * trials) << model.name;
  }
}

// The detected board nearest to `centre` (within 0.3 m), or null.
const BoardCluster* BoardNear(const LidarDetections& out, const Eigen::Vector3d& centre) {
  const BoardCluster* best = nullptr;
  for (const BoardCluster& b : out.boards)
    if ((b.centroid - centre).norm() < 0.3 &&
        (!best || (b.centroid - centre).norm() < (best->centroid - centre).norm()))
      best = &b;
  return best;
}

TEST(LidarDetectorTest, ChainedCellsKeepAllPointsOfAnM1Board) {
  // At 20 m the M1's raster puts two points in some 0.2 deg bins (8% of a board's points when
  // parked, up to a third while driving): the chain keeps them.
  sim::SessionOptions o = Session("m1", "static", 3);
  o.trajectory.static_distance_m = 20.0;
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  LidarDetector chained(LidarDetectorConfig{}, s.lidar_model(), s.workshop().geometries);
  LidarDetectorConfig one_config;
  one_config.cell_range_tolerance_m = 0.0;
  LidarDetector one_per_cell(one_config, s.lidar_model(), s.workshop().geometries);
  LidarDetections out, one;
  int kept = 0, kept_one = 0, total = 0;
  // Successive frames shift the raster against the bins (lidar_sim.cpp): look at several.
  for (int frame = 0; frame < 8; ++frame) {
    s.SimulateFrame(frame, nullptr, &scan, &truth);
    chained.Detect(ViewOf(scan), &out);
    one_per_cell.Detect(ViewOf(scan), &one);
    EXPECT_EQ(one.chained_points, 0);
    const std::vector<Eigen::Vector3d> centres = TrueCentres(s, truth);
    for (size_t b = 0; b < centres.size(); ++b) {
      const BoardCluster* a = BoardNear(out, centres[b]);
      const BoardCluster* c = BoardNear(one, centres[b]);
      ASSERT_NE(a, nullptr) << "frame " << frame << " board " << b;
      total += static_cast<int>(truth.boards[b].lidar_point_indices.size());
      kept += a->cluster_points;
      kept_one += c ? c->cluster_points : 0;
      // The output holds the board's own points.
      int on_board = 0;
      for (int k = a->first_point; k < a->first_point + a->num_points; ++k)
        on_board += scan.board[out.point_indices[k]] == static_cast<int>(b) ? 1 : 0;
      EXPECT_GE(on_board, 0.95 * a->num_points);
    }
  }
  std::cout << "M1 boards at 20 m: " << total << " true points, " << kept << " in clusters ("
            << kept_one << " with one point per cell)\n";
  EXPECT_GE(kept, 0.95 * total);
  EXPECT_LT(kept_one, 0.95 * kept);
}

TEST(LidarDetectorTest, ABoxStandingOnTheFloorIsNoBoardButABoardOnAStandIs) {
  // A 0.7 m panel standing on the floor (a crate's side, 2 cm thick, so that no top or side of
  // it joins its face) and a 0.6 m board on a post, 15 m ahead of a LiDAR 1.95 m up.
  sim::Scene scene;
  sim::Primitive ground;
  ground.shape = sim::Primitive::Shape::kPlaneZ0;
  ground.kind = sim::SurfaceKind::kGround;
  scene.Add(ground);
  auto box = [&](sim::SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
                 double yaw) {
    sim::Primitive p;
    p.kind = kind;
    p.T_world_local = PoseFromXyzRpy(centre, Eigen::Vector3d(0.0, 0.0, yaw));
    p.half_extents = half;
    return scene.Add(p);
  };
  box(sim::SurfaceKind::kClutter, {15.0, 1.5, 0.35}, {0.01, 0.35, 0.35}, 0.1);
  const Eigen::Vector3d board_centre(15.0, -1.5, 1.3);
  sim::PlacedBoard placed;
  placed.T_world_board.translation() = board_centre;
  placed.primitive_index =
      box(sim::SurfaceKind::kBoard, board_centre + Eigen::Vector3d(0.005, 0.0, 0.0),
          {0.005, 0.3, 0.3}, 0.0);
  scene.primitives[placed.primitive_index].board_index = 0;
  scene.boards.push_back(placed);
  sim::Primitive post;
  post.shape = sim::Primitive::Shape::kCylinder;
  post.kind = sim::SurfaceKind::kStand;
  post.T_world_local.translation() = Eigen::Vector3d(15.04, -1.5, 0.0);
  post.radius = 0.02;
  post.height = 1.05;
  scene.Add(post);
  scene.Finalize();

  const LidarModel model = MakeLidarModel(LidarKind::kOt128);
  sim::LidarSimulator lidar(model, sim::LidarNoise{});
  const Pose T_world_lidar = PoseFromXyzRpy({0.0, 0.0, 1.95}, Eigen::Vector3d::Zero());
  sim::LidarScan scan;
  lidar.Scan(scene, T_world_lidar, T_world_lidar, 0, 5, &scan);
  const Eigen::Vector3d board_lidar = T_world_lidar.inverse() * board_centre;
  const Eigen::Vector3d panel_lidar = T_world_lidar.inverse() * Eigen::Vector3d(14.99, 1.5, 0.35);

  LidarDetector detector(LidarDetectorConfig{}, model, {BoardGeometry{}});
  LidarDetectorConfig no_gate;
  no_gate.min_board_clearance_m = 0.0;
  LidarDetector without(no_gate, model, {BoardGeometry{}});
  LidarDetections out, out_without;
  detector.Detect(ViewOf(scan), &out);
  ASSERT_EQ(out.boards.size(), 1u);
  EXPECT_LT((out.boards[0].centroid - board_lidar).norm(), 0.1);
  // Without the clearance gate the panel, its bottom taken by the ground, passes every other gate
  // and the descriptor in some sweeps (in about two thirds the floor's points next to it leave
  // it not planar); with the gate, in none of 20 (the first sweep's, above, and 19 more).
  int panel_found = 0;
  for (uint64_t seed = 6; seed < 25; ++seed) {
    sim::LidarScan sweep;
    lidar.Scan(scene, T_world_lidar, T_world_lidar, 0, seed, &sweep);
    detector.Detect(ViewOf(sweep), &out);
    without.Detect(ViewOf(sweep), &out_without);
    ASSERT_EQ(out.boards.size(), 1u) << "seed " << seed;
    EXPECT_LT((out.boards[0].centroid - board_lidar).norm(), 0.1) << "seed " << seed;
    EXPECT_TRUE(out.clusters.empty());  // reported only when asked (report_clusters)
    for (const BoardCluster& b : out_without.boards)
      panel_found += (b.centroid - panel_lidar).norm() < 0.5 ? 1 : 0;
  }
  EXPECT_GE(panel_found, 3);

  // report_clusters says where each cluster of the first sweep stopped: the board is a board,
  // the panel stands on the floor.
  LidarDetectorConfig reporting;
  reporting.report_clusters = true;
  LidarDetector reporter(reporting, model, {BoardGeometry{}});
  LidarDetections reported;
  reporter.Detect(ViewOf(scan), &reported);
  ASSERT_EQ(reported.boards.size(), 1u);
  const LidarClusterReport* board_report = nullptr;
  int panel_on_ground = 0, panel_boards = 0;  // the panel
  for (const LidarClusterReport& r : reported.clusters) {
    if ((r.centroid - board_lidar).norm() < 0.1) board_report = &r;
    if ((r.centroid - panel_lidar).norm() > 0.5) continue;
    panel_on_ground += r.gate == ClusterGate::kOnGround ? 1 : 0;
    panel_boards += r.gate == ClusterGate::kBoard ? 1 : 0;
  }
  ASSERT_NE(board_report, nullptr);
  EXPECT_EQ(board_report->gate, ClusterGate::kBoard);
  EXPECT_STREQ(ClusterGateName(board_report->gate), "board");
  EXPECT_GE(board_report->score, 0.94);
  EXPECT_NEAR(board_report->rectangle(0), 0.6, 0.15);
  EXPECT_LT(board_report->tilt_deg, 10.0);
  EXPECT_EQ(panel_on_ground, 1);
  EXPECT_EQ(panel_boards, 0);
  EXPECT_STREQ(ClusterGateName(ClusterGate::kOnGround), "on_ground");
}

// A 0.9 m board facing the LiDAR on a thin post, 3.5 m ahead of a LiDAR 1.2 m up, on a floor:
// the scene of the tests below, which add what stands next to it.
struct BoardOnAPost {
  sim::Scene scene;
  const Eigen::Vector3d board_centre{3.5, 0.3, 1.5};
  const Pose T_world_lidar = PoseFromXyzRpy({0.0, 0.0, 1.2}, Eigen::Vector3d::Zero());

  BoardOnAPost() {
    sim::Primitive ground;
    ground.shape = sim::Primitive::Shape::kPlaneZ0;
    ground.kind = sim::SurfaceKind::kGround;
    scene.Add(ground);
    sim::PlacedBoard placed;
    placed.T_world_board.translation() = board_centre;
    placed.primitive_index = AddBox(
        sim::SurfaceKind::kBoard, board_centre + Eigen::Vector3d(0.005, 0, 0), {0.005, 0.45, 0.45});
    scene.primitives[placed.primitive_index].board_index = 0;
    scene.boards.push_back(placed);
    sim::Primitive post;
    post.shape = sim::Primitive::Shape::kCylinder;
    post.kind = sim::SurfaceKind::kStand;
    post.T_world_local.translation() = Eigen::Vector3d(3.54, 0.3, 0.0);
    post.radius = 0.02;
    post.height = 1.05;
    scene.Add(post);
  }
  // A box of half extents `half` at `centre`, turned by `yaw_rad` about the vertical.
  int AddBox(sim::SurfaceKind kind, const Eigen::Vector3d& centre, const Eigen::Vector3d& half,
             double yaw_rad = 0.0) {
    sim::Primitive p;
    p.kind = kind;
    p.T_world_local.translation() = centre;
    p.T_world_local.linear() = Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()).matrix();
    p.half_extents = half;
    return scene.Add(p);
  }
  // One sweep of `kind` with range noise `sigma_m`.
  sim::LidarScan Scan(LidarKind kind, double sigma_m, uint64_t seed = 7) {
    scene.Finalize();
    sim::LidarNoise noise;
    noise.range_sigma_m = sigma_m;
    sim::LidarSimulator lidar(MakeLidarModel(kind), noise);
    sim::LidarScan scan;
    lidar.Scan(scene, T_world_lidar, T_world_lidar, 0, seed, &scan);
    return scan;
  }
  static BoardGeometry Board() {
    BoardGeometry board;
    board.width_m = board.height_m = 0.9;
    board.tag_size_m = 0.7;
    return board;
  }
  // What keeps `out` from being the one detected board ("" when it is): its points are the
  // board's (depth within 4 noise sigmas, sides within 3 cm; a rosette's uneven density moves the
  // centroid, not this) and cover it.
  std::string NotTheBoard(const LidarDetections& out, double sigma_m) const {
    if (out.boards.size() != 1) return std::to_string(out.boards.size()) + " boards";
    const BoardCluster& b = out.boards[0];
    const double depth_tol = 4.0 * sigma_m + 0.01, edge_tol = 0.03;
    int inside = 0;
    Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e9), hi = -lo;
    for (int k = b.first_point; k < b.first_point + b.num_points; ++k) {
      const Eigen::Vector3d p = T_world_lidar * out.points[k].cast<double>();
      const Eigen::Vector3d d = p - board_centre;
      inside += std::fabs(d.x()) < depth_tol && std::fabs(d.y()) < 0.45 + edge_tol &&
                std::fabs(d.z()) < 0.45 + edge_tol;
      lo = lo.cwiseMin(p);
      hi = hi.cwiseMax(p);
    }
    if (inside < 0.95 * b.num_points) return "points off the board";
    if (hi.y() - lo.y() <= 0.7 * 0.9 || hi.z() - lo.z() <= 0.7 * 0.9) return "covers too little";
    if ((b.centroid - T_world_lidar.inverse() * board_centre).norm() >= 0.1) return "centroid off";
    if (std::fabs(b.normal.norm() - 1.0) > 1e-6 || std::fabs(b.normal.x()) <= 0.99)
      return "not facing the sensor";
    return "";
  }
};

// The report of the detected board, or null.
const LidarClusterReport* BoardReport(const LidarDetections& out) {
  for (const LidarClusterReport& r : out.clusters)
    if (r.gate == ClusterGate::kBoard) return &r;
  return nullptr;
}

struct SensorCase {
  const char* name;
  LidarKind kind;
  double range_sigma_m;
  /// The share of the sweeps, and of those where board and wall joined, in which the board must
  /// be found (measured rates, with room for 40 sweeps' binomial scatter).
  double min_found_share = 0.75;
};

std::string SensorCaseName(const ::testing::TestParamInfo<SensorCase>& param) {
  return param.param.name;
}

// The board 0.5 m in front of a wall: with rings 1-2 deg apart the ring above the board's top edge
// hits the wall close enough (in angle) for the segmentation's angle criterion, so board and wall
// come out as one cluster, refused as too large or not a rectangle. extract_planes finds the board
// as a plane inside it; the wall stays out. Not always on a VLP-32C (about half its sweeps, tuned
// on none): its rings 2.3-10.3 deg, 0.7-3.3 deg apart, leave the board's top ring 4-6 cm off the
// plane grown from its dense lower rows, so the plane stops short of the top edge and too much of
// its edge reads attached (max_attached_fraction; docs/accuracy-and-speed.md).
class JoinedBoardTest : public ::testing::TestWithParam<SensorCase> {};

TEST_P(JoinedBoardTest, ABoardJoinedToTheWallBehindItIsFoundAsAPlaneOfItsCluster) {
  BoardOnAPost setup;
  setup.AddBox(sim::SurfaceKind::kWall, {4.05, 0.0, 1.5}, {0.05, 4.0, 1.5});
  const SensorCase& c = GetParam();
  const LidarModel model = MakeLidarModel(c.kind);
  LidarDetectorConfig whole;
  whole.report_clusters = true;
  whole.extract_planes = false;
  LidarDetector paper(whole, model, {BoardOnAPost::Board()});
  LidarDetectorConfig planes = whole;
  planes.extract_planes = true;
  LidarDetector extracting(planes, model, {BoardOnAPost::Board()});
  // Over sweeps of their own noise: whether board and wall join depends on it, and so does what
  // plane extraction makes of the joined cluster (one sweep is one draw of a rate).
  constexpr int kSweeps = 40;
  int joined = 0, found_in_joined = 0, found = 0;
  std::string last_miss;
  for (int k = 0; k < kSweeps; ++k) {
    const sim::LidarScan scan = setup.Scan(c.kind, c.range_sigma_m, 7 + k);
    LidarDetections out;
    paper.Detect(ViewOf(scan), &out);
    // Whole clusters only: the board lost in the wall's cluster.
    const bool lost = out.boards.empty();
    bool large = false;
    for (const LidarClusterReport& r : out.clusters)
      large = large || (r.gate != ClusterGate::kBoard && r.num_points > 500);
    extracting.Detect(ViewOf(scan), &out);
    const LidarClusterReport* report = BoardReport(out);
    std::string why = setup.NotTheBoard(out, c.range_sigma_m);
    if (why.empty() && report == nullptr) why = "no report";
    if (why.empty() && report->attached_fraction > planes.max_attached_fraction)
      why = "attached " + std::to_string(report->attached_fraction);
    if (why.empty() && std::fabs(report->rectangle(0) - 0.9) > 0.15)
      why = "rectangle " + std::to_string(report->rectangle(0));
    const bool is_board = why.empty();
    if (!is_board) last_miss = "sweep " + std::to_string(7 + k) + ": " + why;
    found += is_board ? 1 : 0;
    if (lost && large) {
      ++joined;
      // A plane of a larger segment, not a segment of its own.
      found_in_joined += is_board && report->plane >= 0 ? 1 : 0;
    }
  }
  std::cout << c.name << ": board and wall joined in " << joined << " of " << kSweeps
            << " sweeps, the board found as a plane in " << found_in_joined << " of them; found in "
            << found << " of " << kSweeps << "\n";
  EXPECT_GE(joined, kSweeps / 4)
      << "the board was seldom joined to the wall: the test shows little";
  EXPECT_GE(found_in_joined, c.min_found_share * joined) << last_miss;
  EXPECT_GE(found, c.min_found_share * kSweeps) << last_miss;
}

INSTANTIATE_TEST_SUITE_P(SparseRings, JoinedBoardTest,
                         ::testing::Values(SensorCase{"vlp16_1cm", LidarKind::kVlp16, 0.01},
                                           SensorCase{"vlp16_3cm", LidarKind::kVlp16, 0.03},
                                           SensorCase{"vlp32c_2cm", LidarKind::kVlp32c, 0.02, 0.3},
                                           SensorCase{"os1_64_2cm", LidarKind::kOs1_64, 0.02},
                                           SensorCase{"avia_2cm", LidarKind::kAvia, 0.02},
                                           SensorCase{"mid360_2cm", LidarKind::kMid360, 0.02}),
                         SensorCaseName);

// Still poses as other rigs record them: one 0.9 m board held by a person or on a tripod among
// furniture, 1.5-8 m away, turned and tilted as people place it. A body or a wall crossing the
// board's tilted plane beside it leaves a strip within the plane's noise band, which makes the
// plane too long for a board. Cut to its board-sized window (max_trimmed_fraction), more boards
// are found, and the points of every board cut so are the board's own.
struct StillsCase {
  const char* name;
  const char* lidar;
  unsigned long long seed;
};

class TrimmedBoardTest : public ::testing::TestWithParam<StillsCase> {};

TEST_P(TrimmedBoardTest, BoardsCutFromAStripAcrossTheirPlaneAreFoundWithTheirOwnPoints) {
  sim::SessionOptions o = Session(GetParam().lidar, "stills", GetParam().seed);
  o.trajectory.rate_hz = 0.5;
  o.trajectory.duration_s = 30 / o.trajectory.rate_hz;
  o.workshop.num_boards = 1;
  o.workshop.board_width_m = o.workshop.board_height_m = 0.9;
  o.workshop.tag_size_m = 0.7;
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  LidarDetectorConfig untrimmed;
  untrimmed.extract_planes = true;
  untrimmed.report_clusters = true;
  untrimmed.max_trimmed_fraction = 0.0;
  LidarDetectorConfig trimming = untrimmed;
  trimming.max_trimmed_fraction = LidarDetectorConfig{}.max_trimmed_fraction;
  const std::vector<BoardGeometry> boards = {BoardOnAPost::Board()};
  LidarDetector plain(untrimmed, s.lidar_model(), boards);
  LidarDetector cutting(trimming, s.lidar_model(), boards);
  ASSERT_TRUE(plain.ok() && cutting.ok());
  sim::LidarScan scan;
  sim::FrameTruth truth;
  LidarDetections out;
  int found_plain = 0, found_cut = 0, false_plain = 0, false_cut = 0, cut = 0;
  std::vector<double> shares;  // of own points, in each true board cut to its window
  for (int k = 0; k < s.num_frames(); ++k) {
    s.SimulateFrame(k, nullptr, &scan, &truth);
    const Eigen::Vector3d centre = TrueCentres(s, truth)[0];
    const std::vector<int>& on_board = truth.boards[0].lidar_point_indices;
    plain.Detect(ViewOf(scan), &out);
    for (const BoardCluster& b : out.boards)
      ((b.centroid - centre).norm() < 0.2 ? found_plain : false_plain) += 1;
    cutting.Detect(ViewOf(scan), &out);
    for (const BoardCluster& b : out.boards) {
      const bool true_board = (b.centroid - centre).norm() < 0.2;
      (true_board ? found_cut : false_cut) += 1;
      bool was_cut = false;
      for (const LidarClusterReport& r : out.clusters)
        was_cut = was_cut || (r.gate == ClusterGate::kBoard && r.trimmed_cells > 0 &&
                              (r.centroid - b.centroid).norm() < 1e-6);
      if (!was_cut || !true_board) continue;
      ++cut;
      int own = 0;
      for (int i = b.first_point; i < b.first_point + b.num_points; ++i)
        own += std::binary_search(on_board.begin(), on_board.end(), out.point_indices[i]);
      shares.push_back(double(own) / b.num_points);
    }
  }
  EXPECT_GT(found_cut, found_plain);
  ASSERT_GT(cut, 0);
  std::cout << GetParam().name << ": boards found " << found_plain << " -> " << found_cut << " of "
            << s.num_frames() << " (" << cut << " cut to their window), false " << false_plain
            << " -> " << false_cut << ", share of own points: median " << Median(shares)
            << ", worst " << *std::min_element(shares.begin(), shares.end()) << "\n";
  // Mostly the board's own; a window holds what of the strip crosses it (as much as an eighth
  // of it where the strip runs through the board's middle).
  EXPECT_GE(Median(shares), 0.95);
  EXPECT_GE(*std::min_element(shares.begin(), shares.end()), 0.85);
}

INSTANTIATE_TEST_SUITE_P(Stills, TrimmedBoardTest,
                         ::testing::Values(StillsCase{"avia_seed4", "avia", 4},
                                           StillsCase{"vlp32c_seed2", "vlp32c", 2},
                                           StillsCase{"os1_64_seed4", "os1-64", 4}),
                         [](const ::testing::TestParamInfo<StillsCase>& param) {
                           return std::string(param.param.name);
                         });

TEST(LidarDetectorTest, SampleAreaWeightsCentreBoardsAcrossTheFalconsDenseBand) {
  // Parked 10 m away: boards 0 and 2 straddle the edge of the Falcon's dense band at -3 deg.
  Fixture f("falcon");
  const std::vector<Eigen::Vector3d> centres = TrueCentres(f.session, f.truth);
  LidarDetector weighted(LidarDetectorConfig{}, f.session.lidar_model(),
                         f.session.workshop().geometries);
  LidarDetectorConfig flat_config;
  flat_config.weight_by_sample_area = false;
  flat_config.match_threshold = 0.0;
  LidarDetector flat(flat_config, f.session.lidar_model(), f.session.workshop().geometries);
  LidarDetections out, out_flat;
  weighted.Detect(ViewOf(f.scan), &out);
  flat.Detect(ViewOf(f.scan), &out_flat);
  double error = 0.0, error_flat = 0.0;
  for (const Eigen::Vector3d& c : centres) {
    const BoardCluster* a = BoardNear(out, c);
    const BoardCluster* b = BoardNear(out_flat, c);
    ASSERT_NE(a, nullptr);
    ASSERT_NE(b, nullptr);
    EXPECT_GE(a->score, 0.94);
    error = std::max(error, (a->centroid - c).norm());
    error_flat = std::max(error_flat, (b->centroid - c).norm());
  }
  std::cout << "Falcon at 10 m: worst centroid error " << error << " m weighted, " << error_flat
            << " m unweighted\n";
  EXPECT_LT(error, error_flat);
  EXPECT_LT(error, 0.05);
}

TEST(LidarDetectorTest, StageTimesOfAnOt128Frame) {
  Fixture f("ot128", "drive");
  LidarDetector detector(LidarDetectorConfig{}, f.session.lidar_model(),
                         f.session.workshop().geometries);
  ASSERT_TRUE(detector.ok()) << detector.error();
  LidarDetections out;
  std::vector<LidarStageTimes> times;
  for (int i = 0; i < 15; ++i) {
    detector.Detect(ViewOf(f.scan), &out);
    times.push_back(out.times);
  }
  std::sort(times.begin(), times.end(), [](const LidarStageTimes& a, const LidarStageTimes& b) {
    return a.total_ms < b.total_ms;
  });
  const LidarStageTimes& m = times[times.size() / 2];
  std::cout << "ot128 frame of " << f.scan.size() << " points, median ms: range image "
            << m.range_image_ms << ", ground " << m.ground_ms << ", segmentation "
            << m.segmentation_ms << ", descriptors " << m.descriptor_ms << ", total " << m.total_ms
            << "\n";
  EXPECT_FALSE(out.boards.empty());
}

TEST(LidarDetectorTest, PrecisionAndRecallOnDrivingSessions) {
  const int frames = EnvInt("CALIBD_LIDAR_EVAL_FRAMES", 10);
  const bool verbose = EnvInt("CALIBD_LIDAR_EVAL_VERBOSE", 0) != 0;
  for (const std::string lidar : {"ot128", "m1", "falcon"}) {
    LidarStageTimes t;
    const Tally tally = Evaluate(lidar, "drive", frames, 30, &t, verbose);
    std::cout << lidar << ": " << frames << " frames, TP " << tally.tp << " FP " << tally.fp
              << " FN " << tally.fn << ", precision " << tally.precision() << ", recall "
              << tally.recall() << "; mean ms: range image " << t.range_image_ms << ", ground "
              << t.ground_ms << ", segmentation " << t.segmentation_ms << ", descriptors "
              << t.descriptor_ms << ", total " << t.total_ms << "\n";
    EXPECT_GE(tally.precision(), 0.99) << lidar;
    EXPECT_GE(tally.recall(), 0.95) << lidar;
  }
}

}  // namespace
}  // namespace calibd
