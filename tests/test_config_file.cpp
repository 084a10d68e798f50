#include "calibd/drivers/config_file.hpp"

#include <gtest/gtest.h>

#include <fstream>

#include "calibd/core/lidar/lidar_resolution.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

CalibConfig Example() {
  CalibConfig c;
  c.camera_id = "front";
  c.lidar_id = "roof";
  c.lidar_model = "m1";
  for (int i = 0; i < 3; ++i) {
    BoardGeometry g;
    g.board_id = i;
    g.tag_id = 10 + i;
    c.boards.push_back(g);
  }
  c.prior_T_camera_lidar = PoseFromXyzRpy({0.1, -0.2, 0.3}, {-1.6, 0.02, -1.55});
  return c;
}

TEST(ConfigFileTest, RoundTripsThroughYaml) {
  const CalibConfig c = Example();
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(ConfigToYaml(c), &back, &error)) << error;
  EXPECT_EQ(back.camera_id, "front");
  EXPECT_EQ(back.lidar_model, "m1");
  ASSERT_EQ(back.boards.size(), 3u);
  EXPECT_EQ(back.boards[2].tag_id, 12);
  EXPECT_DOUBLE_EQ(back.boards[1].tag_size_m, 0.48);
  EXPECT_DOUBLE_EQ(back.camera.k3, c.camera.k3);
  EXPECT_TRUE(back.prior_T_camera_lidar.isApprox(c.prior_T_camera_lidar, 1e-15));
  EXPECT_EQ(back.principal_point_sigma_px, 0.0);  // not stated: not written
}

// The intrinsic calibration's stated principal point sigma: written when stated, read back, and
// refused when negative.
TEST(ConfigFileTest, PrincipalPointSigmaRoundTripsAndANegativeIsRefused) {
  CalibConfig c = Example();
  c.principal_point_sigma_px = 0.8;
  const std::string yaml = ConfigToYaml(c);
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(yaml, &back, &error)) << error;
  EXPECT_EQ(back.principal_point_sigma_px, 0.8);
  std::string negative = yaml;
  negative.replace(negative.find("principal_point_sigma_px: 0.8"),
                   std::string("principal_point_sigma_px: 0.8").size(),
                   "principal_point_sigma_px: -1");
  EXPECT_FALSE(ParseConfigYaml(negative, &back, &error));
  EXPECT_EQ(error.rfind("camera.principal_point_sigma_px", 0), 0u) << error;
}

// A checkerboard carries no tag: beside a tag with id 0 it round-trips (its tag_id, not
// written, reads back as 0 and is no identity); two tags with one id stay an error.
TEST(ConfigFileTest, CheckerboardBesideATagWithIdZeroRoundTrips) {
  CalibConfig c = Example();
  c.boards[0].tag_id = 0;
  c.boards[1].pattern = BoardGeometry::PatternKind::kCheckerboard;
  c.boards[1].width_m = 0.8;
  c.boards[1].checker_square_size_m = 0.08;
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(ConfigToYaml(c), &back, &error)) << error;
  ASSERT_EQ(back.boards.size(), 3u);
  EXPECT_EQ(back.boards[1].pattern, BoardGeometry::PatternKind::kCheckerboard);
  EXPECT_EQ(back.boards[1].checker_inner_cols, 7);
  c.boards[1].pattern = BoardGeometry::PatternKind::kAprilTag;
  c.boards[1].tag_id = 0;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_EQ(error.rfind("boards[1].tag_id", 0), 0u) << error;
}

TEST(ConfigFileTest, SaveAndLoadThroughAFile) {
  testing::TempDir dir;
  std::string error;
  ASSERT_TRUE(SaveConfigFile(dir.file("calib.yaml"), Example(), &error)) << error;
  CalibConfig back;
  ASSERT_TRUE(LoadConfigFile(dir.file("calib.yaml"), &back, &error)) << error;
  EXPECT_EQ(back.boards.size(), 3u);
}

struct BadCase {
  std::string find, replace, expected_key;
};

class ConfigFileBadKeyTest : public ::testing::TestWithParam<BadCase> {};

TEST_P(ConfigFileBadKeyTest, ErrorNamesTheKey) {
  std::string yaml = ConfigToYaml(Example());
  const auto& p = GetParam();
  const auto pos = yaml.find(p.find);
  ASSERT_NE(pos, std::string::npos) << p.find;
  yaml.replace(pos, p.find.size(), p.replace);
  CalibConfig c;
  std::string error;
  EXPECT_FALSE(ParseConfigYaml(yaml, &c, &error));
  EXPECT_EQ(error.rfind(p.expected_key, 0), 0u) << "error was: " << error;
}

INSTANTIATE_TEST_SUITE_P(
    Keys, ConfigFileBadKeyTest,
    ::testing::Values(BadCase{"fx: ", "fx: -", "camera.intrinsics"},
                      BadCase{"model: m1", "model: velodyne", "lidar.model"},
                      BadCase{"tag_size_m: 0.48", "tag_size_m: big", "boards[0].tag_size_m"},
                      BadCase{"tag_id: 11", "tag_id: 10", "boards[1].tag_id"},
                      BadCase{"  width: ", "  widht: 1\n  width: ", "camera.widht"},
                      BadCase{"distortion: [", "distortion: [1, ", "camera.distortion"},
                      BadCase{"    - [0, 0, 0, 1]", "    - [0, 0, 1, 1]",
                              "prior.T_camera_lidar[3]"},
                      BadCase{"lidar:\n  id: roof\n", "lidar:\n", "lidar.id"},
                      BadCase{"model: radtan", "model: fisheye", "camera.model"},
                      BadCase{"pattern: apriltag", "pattern: dots", "boards[0].pattern"},
                      BadCase{"frame_id: camera", "frame_id: /camera", "camera.frame_id"},
                      BadCase{"frame_id: camera", "frame_id: \"cam era\"", "camera.frame_id"},
                      BadCase{"frame_id: camera", "frame_id: \"\"", "camera.frame_id"},
                      BadCase{"frame_id: lidar", "frame_id: [lidar]", "lidar.frame_id"},
                      BadCase{"frame_id: lidar", "frame_id: camera", "lidar.frame_id"},
                      // fuzz_calib_config: an id that ConfigToYaml could not write back.
                      BadCase{"id: front", "id: \"front \\x01\"", "camera.id"},
                      BadCase{"id: roof", "id: \"roof \"", "lidar.id"},
                      BadCase{"id: roof", "id: \"\"", "lidar.id"},
                      // fuzz_calib_config: a family with a NUL before its name did not round-trip
                      // (crash-tag-family-nul); any family the detector does not know is refused.
                      BadCase{"tag_family: tag36h11", "tag_family: \"\\0tag36h11\"", "boards[0]"},
                      BadCase{"tag_family: tag36h11", "tag_family: tag36h12", "boards[0]"}));

TEST(ConfigFileTest, FrameIdsRoundTripAndDefault) {
  CalibConfig c = Example();
  c.camera_frame = "cam_front/optical";
  c.lidar_frame = "lidar_roof.top";
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(ConfigToYaml(c), &back, &error)) << error;
  EXPECT_EQ(back.camera_frame, "cam_front/optical");
  EXPECT_EQ(back.lidar_frame, "lidar_roof.top");
  // Files written before the keys existed still load, with the defaults.
  std::string yaml = ConfigToYaml(Example());
  for (const std::string key : {"  frame_id: camera\n", "  frame_id: lidar\n"}) {
    const auto pos = yaml.find(key);
    ASSERT_NE(pos, std::string::npos) << key;
    yaml.erase(pos, key.size());
  }
  ASSERT_TRUE(ParseConfigYaml(yaml, &back, &error)) << error;
  EXPECT_EQ(back.camera_frame, "camera");
  EXPECT_EQ(back.lidar_frame, "lidar");
}

TEST(ConfigFileTest, FisheyeCameraAndCheckerboardRoundTrip) {
  CalibConfig c = Example();
  c.camera.model = DistortionModel::kKannalaBrandt;
  c.camera.k1 = 0.1;
  c.camera.k2 = -0.02;
  c.camera.p1 = c.camera.p2 = 0.0;
  c.camera.k3 = 0.003;
  c.camera.k4 = -0.0004;
  c.boards.resize(1);
  c.boards[0].pattern = BoardGeometry::PatternKind::kCheckerboard;
  c.boards[0].checker_inner_rows = 4;
  c.boards[0].checker_inner_cols = 6;
  c.boards[0].checker_square_size_m = 0.08;
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(ConfigToYaml(c), &back, &error)) << error;
  EXPECT_EQ(back.camera.model, DistortionModel::kKannalaBrandt);
  EXPECT_DOUBLE_EQ(back.camera.k4, -0.0004);
  EXPECT_EQ(back.boards[0].pattern, BoardGeometry::PatternKind::kCheckerboard);
  EXPECT_EQ(back.boards[0].checker_inner_cols, 6);
  EXPECT_DOUBLE_EQ(back.boards[0].checker_square_size_m, 0.08);
}

TEST(ConfigFileTest, GenericLidarKeysRoundTripAndNameTheBadKey) {
  CalibConfig c = Example();
  c.lidar_model = "generic";
  c.lidar_generic.azimuth_resolution_deg = 0.1;
  c.lidar_generic.elevation_min_deg = -15.0;
  c.lidar_generic.elevation_max_deg = 15.0;
  c.lidar_generic.max_points = 250000;
  c.lidar_generic.pattern = GenericLidarConfig::Pattern::kIrregular;
  c.lidar_generic.points_per_frame = 24000;
  const std::string yaml = ConfigToYaml(c);
  CalibConfig back;
  std::string error;
  ASSERT_TRUE(ParseConfigYaml(yaml, &back, &error)) << error << "\n" << yaml;
  EXPECT_EQ(back.lidar_model, "generic");
  EXPECT_EQ(back.lidar_generic.azimuth_resolution_deg, 0.1);
  EXPECT_EQ(back.lidar_generic.elevation_resolution_deg, 0.0);  // estimated
  EXPECT_EQ(back.lidar_generic.elevation_min_deg, -15.0);
  EXPECT_EQ(back.lidar_generic.max_points, 250000);
  EXPECT_EQ(back.lidar_generic.pattern, GenericLidarConfig::Pattern::kIrregular);
  EXPECT_EQ(back.lidar_generic.points_per_frame, 24000);
  // Only the model name is needed: every generic value has a default.
  std::string minimal = ConfigToYaml(Example());
  minimal.replace(minimal.find("model: m1"), 9, "model: generic");
  ASSERT_TRUE(ParseConfigYaml(minimal, &back, &error)) << error;
  EXPECT_EQ(back.lidar_generic.max_points, GenericLidarConfig{}.max_points);
  // A misspelt or out-of-range key names itself.
  std::string bad = yaml;
  bad.replace(bad.find("max_points: 250000"), 18, "max_point: 250000");
  EXPECT_FALSE(ParseConfigYaml(bad, &back, &error));
  EXPECT_EQ(error.rfind("lidar.generic.max_point", 0), 0u) << error;
  bad = yaml;
  bad.replace(bad.find("azimuth_resolution_deg: 0.1"), 27, "azimuth_resolution_deg: -1");
  EXPECT_FALSE(ParseConfigYaml(bad, &back, &error));
  EXPECT_EQ(error.rfind("lidar.generic.azimuth_resolution_deg", 0), 0u) << error;
  bad = yaml;
  bad.replace(bad.find("pattern: irregular"), 18, "pattern: rosette");
  EXPECT_FALSE(ParseConfigYaml(bad, &back, &error));
  EXPECT_EQ(error.rfind("lidar.generic.pattern", 0), 0u) << error;
  EXPECT_NE(error.find("auto, lines or irregular"), std::string::npos) << error;
  // An irregular pattern needs its density to make a model without frames.
  GenericLidarConfig irregular = c.lidar_generic;
  irregular.azimuth_resolution_deg = irregular.elevation_resolution_deg = 0.4;
  irregular.azimuth_min_deg = -35.0;
  irregular.azimuth_max_deg = 35.0;
  irregular.pattern = GenericLidarConfig::Pattern::kIrregular;
  LidarModel model;
  ASSERT_TRUE(MakeGenericLidarModel(irregular, nullptr, &model, &error)) << error;
  EXPECT_TRUE(model.non_repetitive);
  EXPECT_EQ(model.pattern_points_per_frame, 24000);
  irregular.points_per_frame = 0;
  EXPECT_FALSE(irregular.complete());
  EXPECT_FALSE(MakeGenericLidarModel(irregular, nullptr, &model, &error));
}

TEST(ConfigFileTest, MissingFileNamesThePath) {
  CalibConfig c;
  std::string error;
  EXPECT_FALSE(LoadConfigFile("/nonexistent/calib.yaml", &c, &error));
  EXPECT_NE(error.find("/nonexistent/calib.yaml"), std::string::npos);
}

TEST(ConfigFileTest, NonRotationPriorIsRejected) {
  CalibConfig c = Example();
  c.prior_T_camera_lidar.matrix()(0, 0) = 2.0;
  std::string error;
  EXPECT_FALSE(c.IsValid(&error));
  EXPECT_EQ(error.rfind("prior.T_camera_lidar", 0), 0u) << error;
}

}  // namespace
}  // namespace calibd
