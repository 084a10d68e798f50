#pragma once
/// \file
/// The figures of `calibd-bench calib` as JSON: per LiDAR and experiment a summary over the drives
/// and every run (verdict, reason, errors), beside the paper's figures and our targets.

#include <nlohmann/json.hpp>
#include <vector>

#include "calib_bench.hpp"
#include "calib_experiments.hpp"

namespace calibd::bench {

nlohmann::json CalibJson(const CalibBenchOptions& options,
                         const std::vector<LidarResults>& results);

}  // namespace calibd::bench
