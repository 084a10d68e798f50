#pragma once
// The library headers nearly every test program includes, precompiled once per build
// (calibd_test_pch in tests/CMakeLists.txt): GoogleTest alone is about a second of parsing in
// each of the ~100 test files. Library headers only, so that the header never changes with the
// project's own code.
#include <gtest/gtest.h>

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <random>
#include <sstream>
#include <string>
#include <thread>
#include <vector>
