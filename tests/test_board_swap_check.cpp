// Boards of different sizes whose ids the config swaps, told from each board's camera distances
// against the LiDAR's (board_swap_check.hpp): rows made up of board observations whose camera
// distance is the LiDAR's times a ratio per board.

#include "calibd/core/verdict/board_swap_check.hpp"

#include <gtest/gtest.h>

#include <deque>

namespace calibd {
namespace {

std::vector<BoardGeometry> Boards() {
  std::vector<BoardGeometry> boards(3);
  for (int i = 0; i < 3; ++i) {
    boards[static_cast<size_t>(i)].board_id = boards[static_cast<size_t>(i)].tag_id = i;
  }
  boards[0].width_m = boards[0].height_m = 0.6;
  boards[0].tag_size_m = 0.48;
  boards[1].width_m = boards[1].height_m = 0.42;
  boards[1].tag_size_m = 0.336;  // 70 % of board 0
  boards[2] = boards[0];
  boards[2].board_id = boards[2].tag_id = 2;
  return boards;
}

// `count` observations of each board at 3-9 m, the camera's distance the LiDAR's times
// ratios[board] (the observations live in `store`, which must outlive the rows).
std::vector<BoardDistance> Rows(const std::vector<double>& ratios, int count,
                                std::deque<BoardObservation>* store) {
  std::vector<BoardDistance> rows;
  for (size_t b = 0; b < ratios.size(); ++b) {
    for (int k = 0; k < count; ++k) {
      store->emplace_back();
      store->back().board_index = static_cast<int>(b);
      BoardDistance d;
      d.observation = &store->back();
      d.lidar_m = 3.0 + 6.0 * k / count;
      // +-1 % of scatter about the ratio.
      d.camera_m = d.lidar_m * ratios[b] * (1.0 + 0.01 * ((k % 3) - 1));
      rows.push_back(d);
    }
  }
  return rows;
}

TEST(BoardSwapCheckTest, SwappedIdsAreToldFromRightOnesAndFromAScaleCommonToTheBoards) {
  const std::vector<BoardGeometry> boards = Boards();
  std::deque<BoardObservation> store;
  // Swapped: board 0's tag (config 0.48 m) is the 0.336 m one: PnP puts it 1/0.7 too far.
  const BoardSwap swapped = FindSwapInDistances(boards, Rows({1.0 / 0.7, 0.7, 1.0}, 10, &store));
  ASSERT_TRUE(swapped.found);
  EXPECT_EQ(swapped.board_a, 0);
  EXPECT_EQ(swapped.board_b, 1);
  EXPECT_NEAR(swapped.ratio_a, 1.0 / 0.7, 0.02);
  EXPECT_NEAR(swapped.ratio_b, 0.7, 0.02);
  // Boards 1 and 2 (the same sizes as 0 and 1 on the other side): found as the pair 1, 2.
  const BoardSwap other = FindSwapInDistances(boards, Rows({1.0, 0.7, 1.0 / 0.7}, 10, &store));
  ASSERT_TRUE(other.found);
  EXPECT_EQ(other.board_a, 1);
  EXPECT_EQ(other.board_b, 2);
  // Right ids: ratios near 1.
  EXPECT_FALSE(FindSwapInDistances(boards, Rows({1.02, 0.98, 1.0}, 10, &store)).found);
  // A camera scale error common to every board (a wrong focal length: camera_scale_mismatch's
  // case), even one as large as the swap would give board 0.
  EXPECT_FALSE(FindSwapInDistances(boards, Rows({1.2, 1.2, 1.2}, 10, &store)).found);
  EXPECT_FALSE(FindSwapInDistances(boards, Rows({0.8, 0.8, 0.8}, 10, &store)).found);
  // Half-way (each board 8 % off where a swap gives 43 % and -30 %): not a swap.
  EXPECT_FALSE(FindSwapInDistances(boards, Rows({1.08, 0.92, 1.0}, 10, &store)).found);
  // Too few observations of a board for its median.
  EXPECT_FALSE(
      FindSwapInDistances(boards, Rows({1.0 / 0.7, 0.7, 1.0}, kMinSwapObservations - 1, &store))
          .found);
  // Boards of one size are never a swap, whatever their distances.
  std::vector<BoardGeometry> alike = boards;
  alike[1] = alike[0];
  alike[1].board_id = alike[1].tag_id = 1;
  EXPECT_FALSE(FindSwapInDistances(alike, Rows({1.0 / 0.7, 0.7, 1.0}, 10, &store)).found);
}

}  // namespace
}  // namespace calibd
