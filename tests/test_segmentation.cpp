// Ground removal and range-image segmentation (Bogoslavskyi & Stachniss 2016) on simulated
// workshop sweeps: each board comes out as one cluster, apart from its stand and the wall.

#include "calibd/core/lidar/segmentation.hpp"

#include <gtest/gtest.h>

#include <map>
#include <string>

#include "session.hpp"
#include "small_camera.hpp"

namespace calibd {
namespace {

class SegmentationTest : public ::testing::TestWithParam<std::string> {};

TEST_P(SegmentationTest, EachBoardIsOneClusterApartFromItsStandAndTheWall) {
  sim::SessionOptions o;
  o.lidar_model = GetParam();
  o.trajectory.mode = "static";
  o.trajectory.static_distance_m = 8.0;
  o.camera = testing::SmallCamera();
  sim::SessionSimulator s;
  std::string error;
  ASSERT_TRUE(s.Init(o, &error)) << error;
  sim::LidarScan scan;
  sim::FrameTruth truth;
  s.SimulateFrame(0, nullptr, &scan, &truth);

  RangeImage image;
  image.Configure(s.lidar_model(), 1.0, 60.0, 2 * scan.size());
  PointCloudView view{scan.x.data(), scan.y.data(), scan.z.data(), scan.ring.data(), scan.size()};
  RangeImageStats stats;
  image.Build(view, &stats);
  RangeSegmenter seg;
  SegmentationConfig config;
  config.min_row_width_m = 0.35 * 0.6;
  seg.Configure(image, config);
  seg.LabelGround(image);
  seg.Cluster(image);

  // Ground: the LiDAR is 1.95 m above the floor; kept cells below -1.85 m are floor.
  int floor_cells = 0, floor_labelled = 0;
  for (int i = 0; i < image.rows() * image.cols(); ++i) {
    if (image.cell(i).index < 0 || image.cell(i).z > -1.85f) continue;
    ++floor_cells;
    floor_labelled += seg.labels()[i] == kLabelGround ? 1 : 0;
  }
  EXPECT_GT(floor_labelled, 0.9 * floor_cells);

  for (size_t b = 0; b < truth.boards.size(); ++b) {
    // Labels of the board's kept cells.
    std::map<int32_t, int> votes;
    int board_cells = 0;
    for (int idx : truth.boards[b].lidar_point_indices) {
      const int cell = image.point_cell()[idx];
      if (cell < 0 || image.cell(cell).index != idx) continue;
      ++board_cells;
      ++votes[seg.labels()[cell]];
    }
    ASSERT_GT(board_cells, 50) << "board " << b;
    int32_t label = 0;
    int best = 0;
    for (const auto& [l, n] : votes)
      if (n > best) {
        best = n;
        label = l;
      }
    ASSERT_GT(label, 0) << "board " << b << " is mostly ground or pruned";
    EXPECT_GE(best, 0.9 * board_cells) << "board " << b;
    // The cluster holds few points that are not on the board (stand, wall, floor).
    int cluster_cells = 0, foreign = 0;
    for (int i = 0; i < image.rows() * image.cols(); ++i) {
      if (seg.labels()[i] != label) continue;
      ++cluster_cells;
      foreign += scan.board[image.cell(i).index] == static_cast<int16_t>(b) ? 0 : 1;
    }
    EXPECT_LE(foreign, 0.05 * cluster_cells) << "board " << b;
    // And it is reported as a segment.
    bool reported = false;
    for (int k = 0; k < seg.num_segments(); ++k) reported |= seg.segment(k).label == label;
    EXPECT_TRUE(reported) << "board " << b;
  }
}

INSTANTIATE_TEST_SUITE_P(Models, SegmentationTest, ::testing::Values("ot128", "m1", "falcon"));

}  // namespace
}  // namespace calibd
