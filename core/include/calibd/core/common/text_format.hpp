#pragma once
/// \file
/// Numbers in messages, tables and reports: one formatting for every layer.

#include <string>

namespace calibd {

/// `v` with a fixed number of decimals (0.100 for 0.1 with 3).
std::string FixedDecimal(double v, int decimals = 3);

}  // namespace calibd
