#pragma once
// Test helper: a JSON file (a report, a truth file) parsed whole; a read error fails the test.

#include <gtest/gtest.h>

#include <nlohmann/json.hpp>
#include <string>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd::testing {

inline nlohmann::json ReadJson(const std::string& path) {
  std::string text, error;
  EXPECT_TRUE(ReadWholeFile(path, &text, &error)) << error;
  return nlohmann::json::parse(text);
}

}  // namespace calibd::testing
