// The LiDAR detector's reference descriptors kept between starts (reference_set.hpp): a detector
// given an earlier one's references takes them when they fit, and detects as that one did;
// references built for other boards, by other code (tampered values stand for it) or malformed
// are refused with the reason, and built instead.

#include <gtest/gtest.h>

#include <limits>
#include <vector>

#include "calibd/core/lidar/board_references.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"

namespace calibd {
namespace {

// One noisy sampling per reference view instead of LidarDetectorConfig's 4: a quarter of the
// build, the same code path (the sanitizer build runs this).
LidarDetectorConfig Config() {
  LidarDetectorConfig c;
  c.reference_samples = 1;
  return c;
}

struct Fixture {
  LidarModel model = MakeLidarModel(LidarKind::kVlp16);
  std::vector<BoardGeometry> boards = std::vector<BoardGeometry>(2);
  Fixture() {
    boards[1].board_id = 1;
    boards[1].width_m = 0.8;
  }
};

// Scores of a few simulated boards and a wall-sized patch: what a detector makes of clusters.
std::vector<double> Scores(LidarDetector* detector, const LidarModel& model) {
  std::vector<double> scores;
  std::vector<Eigen::Vector3f> points;
  for (const BoardView& view : {BoardView{3.0, 0.0, 20.0, 0.0}, BoardView{7.5, -4.0, -35.0, 10.0},
                                BoardView{12.0, 2.0, 5.0, -5.0}}) {
    SimulateBoardCluster(model, 0.6, 0.6, view, &points);
    scores.push_back(detector->ScoreCluster(points));
  }
  SimulateBoardCluster(model, 2.5, 1.2, BoardView{5.0, 0.0, 0.0, 0.0}, &points);
  scores.push_back(detector->ScoreCluster(points));
  return scores;
}

TEST(LidarReferencesTest, ADetectorTakesAnEarlierOnesReferencesAndScoresAsItDid) {
  const Fixture f;
  LidarDetector built(Config(), f.model, f.boards);
  ASSERT_TRUE(built.ok()) << built.error();
  EXPECT_FALSE(built.references_from_cache());
  const LidarReferenceSet kept = built.references();
  EXPECT_EQ(kept.key, LidarDetector::ReferenceKey(Config(), f.model, f.boards));
  ASSERT_EQ(static_cast<int>(kept.views.size()), built.num_references());
  EXPECT_EQ(kept.descriptors.size(), kept.views.size() * static_cast<size_t>(kept.dims));

  LidarDetector taken(Config(), f.model, f.boards, nullptr, &kept);
  ASSERT_TRUE(taken.ok()) << taken.error();
  EXPECT_TRUE(taken.references_from_cache()) << taken.cache_refusal();
  EXPECT_EQ(taken.num_references(), built.num_references());
  EXPECT_EQ(taken.references().descriptors, kept.descriptors);
  const std::vector<double> expected = Scores(&built, f.model);
  EXPECT_GT(expected[0], 0.94);  // a board scores as one: the comparison below means something
  EXPECT_EQ(Scores(&taken, f.model), expected);
}

TEST(LidarReferencesTest, ReferencesOfOtherBoardsOtherCodeOrMalformedAreRefusedAndBuilt) {
  const Fixture f;
  LidarDetector built(Config(), f.model, f.boards);
  ASSERT_TRUE(built.ok()) << built.error();
  const LidarReferenceSet kept = built.references();
  const std::vector<double> expected = Scores(&built, f.model);

  // Another board size: another key.
  std::vector<BoardGeometry> other_boards = f.boards;
  other_boards[1].width_m = 0.7;
  EXPECT_NE(LidarDetector::ReferenceKey(Config(), f.model, other_boards), kept.key);
  LidarDetector other(Config(), f.model, other_boards, nullptr, &kept);
  ASSERT_TRUE(other.ok()) << other.error();
  EXPECT_FALSE(other.references_from_cache());
  EXPECT_EQ(other.cache_refusal(), "built for another config, LiDAR model or board sizes");
  // ... and another descriptor setting or LiDAR model.
  LidarDetectorConfig samples = Config();
  samples.reference_samples = 3;
  EXPECT_NE(LidarDetector::ReferenceKey(samples, f.model, f.boards), kept.key);
  EXPECT_NE(LidarDetector::ReferenceKey(Config(), MakeLidarModel(LidarKind::kOs1_64), f.boards),
            kept.key);

  // The same key over descriptors another build of calibd would not make: the sample built
  // again tells; the detector builds its own and scores as the first one.
  LidarReferenceSet tampered = kept;
  for (float& v : tampered.descriptors) v *= 1.01f;
  LidarDetector rebuilt(Config(), f.model, f.boards, nullptr, &tampered);
  ASSERT_TRUE(rebuilt.ok()) << rebuilt.error();
  EXPECT_FALSE(rebuilt.references_from_cache());
  EXPECT_NE(rebuilt.cache_refusal().find("built again differs from the cached one"),
            std::string::npos)
      << rebuilt.cache_refusal();
  EXPECT_EQ(Scores(&rebuilt, f.model), expected);

  // Shapes that cannot be a detector's references.
  auto refusal = [&](const LidarReferenceSet& set) {
    LidarDetector d(Config(), f.model, f.boards, nullptr, &set);
    EXPECT_TRUE(d.ok()) << d.error();
    EXPECT_FALSE(d.references_from_cache());
    return d.cache_refusal();
  };
  LidarReferenceSet short_set = kept;
  short_set.descriptors.pop_back();
  EXPECT_NE(refusal(short_set).find("malformed"), std::string::npos);
  LidarReferenceSet unordered = kept;
  std::swap(unordered.views[0], unordered.views[1]);
  EXPECT_NE(refusal(unordered).find("malformed"), std::string::npos);
  LidarReferenceSet not_finite = kept;
  not_finite.descriptors[5] = std::numeric_limits<float>::quiet_NaN();
  EXPECT_NE(refusal(not_finite).find("malformed"), std::string::npos);
  EXPECT_EQ(refusal(LidarReferenceSet{}),
            "built for another config, LiDAR model or board sizes");  // an empty set: key 0
}

}  // namespace
}  // namespace calibd
