#pragma once
// Test helpers for the agent's end-to-end tests: the ground truth written by calibd-sim --truth
// and the messages the agent published into a file:// log (--publish-url).

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "calibd/core/common/geometry.hpp"
#include "calibd/drivers/agent_outputs.hpp"
#include "calibd/drivers/atomic_file.hpp"

namespace calibd::testing {

/// The true T_camera_lidar of a calibd-sim truth file.
inline Pose TruthExtrinsic(const std::string& path) {
  std::string text, error;
  EXPECT_TRUE(ReadWholeFile(path, &text, &error)) << error;
  const auto j = nlohmann::json::parse(text);
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = j["T_camera_lidar"][r][c].get<double>();
  return T;
}

/// What the agent published (drivers/agent_outputs.hpp); every message must decode.
using Published = AgentOutputs;

inline Published ReadPublished(const std::string& path) {
  Published p;
  std::string error;
  EXPECT_TRUE(ReadAgentOutputs(path, &p, &error)) << error;
  EXPECT_EQ(p.undecodable, 0) << path;
  return p;
}

}  // namespace calibd::testing
