#pragma once
/// \file
/// cv::RNG's normal draws from several threads at once.

#include <opencv2/core.hpp>

namespace calibd::sim {

/// Fills OpenCV's ziggurat tables before any thread draws a normal: OpenCV builds them on the
/// first draw behind an unsynchronised flag, so two threads drawing first would race. The tables
/// are built once, under the guard of a function-local static.
inline void PrepareOpenCvNormals() {
  static const bool ready = [] {
    cv::RNG(1).gaussian(1.0);
    return true;
  }();
  (void)ready;
}

}  // namespace calibd::sim
