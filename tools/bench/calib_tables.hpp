#pragma once
/// \file
/// The tables of `calibd-bench calib`, with the paper's figures beside ours.

#include <iosfwd>
#include <vector>

#include "calib_bench.hpp"
#include "calib_experiments.hpp"

namespace calibd::bench {

void PrintCalibTables(const CalibBenchOptions& options, const std::vector<LidarResults>& results,
                      std::ostream& out);

}  // namespace calibd::bench
