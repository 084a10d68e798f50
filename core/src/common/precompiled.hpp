#pragma once
// The headers nearly every source of calibd_core includes (Eigen's dense core and geometry, the
// standard library), compiled once per build into a precompiled header (core/CMakeLists.txt).
// Parsed by each file in turn they took about a third of the library's compile time; what a
// file includes itself stays in the file, so a file reads the same with or without it.

#include <Eigen/Core>
#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <Eigen/LU>
#include <algorithm>
#include <array>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>
