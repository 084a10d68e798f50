// LidarDetector (paper §III-C) end to end on simulated sweeps: precision/recall against the
// simulator's truth, candidates for the hard negatives, empty and broken inputs, bad configs and
// fixed memory.

#include "calibd/core/lidar_detector.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <random>
#include <string>
#include <vector>

#include "calibd/core/board_references.hpp"
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
