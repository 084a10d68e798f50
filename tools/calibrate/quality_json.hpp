#pragma once
/// \file
/// The engine's quality figures as report.json writes them (calibd-calibrate's report, and each
/// session of calibd-bench verdicts --json): one list of names for both.

#include <nlohmann/json.hpp>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd {

nlohmann::json QualityJson(const QualityFigures& q);

}  // namespace calibd
