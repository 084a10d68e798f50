#pragma once
/// \file
/// Our targets for `calibd-bench calib` and the figures the paper reports (§IV), for the tables
/// and the JSON.

#include <cmath>
#include <iterator>
#include <limits>
#include <string>

namespace calibd::bench {

// Our targets and the paper's figures.
inline constexpr double kRotationTargetDeg = 0.05, kTranslationTargetM = 0.015;
inline constexpr double kGridTargetMs = 50.0, kOptimiseTargetMs = 300.0;
// §IV-E, 200 pairs, i7-10750H (12 threads): grid search, direct (Eq. 4) and indirect optimisation,
// LiDAR and camera detection of the whole session.
inline constexpr double kPaperGridMs = 120.0, kPaperOptimiseMs = 1250.0, kPaperIndirectMs = 1630.0,
                        kPaperLidarDetectMs = 18700.0, kPaperCameraDetectMs = 4930.0;
inline constexpr int kPaperTrials = 100, kPaperConvergedWith = 100,
                     kPaperConvergedWithout = 6;  // §IV-D

/// Paper Table I (indirect method, mean reprojection error in px), one column per LiDAR, rows in
/// kPaperAlphasM's order.
inline constexpr double kPaperAlphasM[] = {0.1, 0.06, 0.05, 0.04, 0.03, 0.02, 0.01, 0.0};
struct PaperTableIColumn {
  const char* lidar;
  const char* vendor;
  double px[8];
};
inline constexpr PaperTableIColumn kPaperTableI[] = {
    {"m1", "Robosense", {9.313, 7.519, 7.083, 6.807, 6.528, 6.425, 6.322, 6.351}},
    {"falcon", "Innovusion", {5.785, 4.718, 4.372, 4.243, 4.095, 4.061, 4.031, 3.983}},
    {"ot128", "Hesai", {8.144, 6.310, 5.775, 5.348, 5.071, 5.013, 5.058, 4.824}}};

/// Paper Table II (dataset not named; Euler angles of its extrinsic), deg:
/// [close, far][indirect, direct (Eq. 4)][roll, pitch, yaw].
inline constexpr double kPaperTableII[2][2][3] = {{{0.840, 0.165, 0.437}, {0.213, 0.159, 0.220}},
                                                  {{0.304, 0.802, 0.370}, {0.215, 0.307, 0.372}}};

inline const PaperTableIColumn* PaperColumn(const std::string& lidar) {
  for (const auto& c : kPaperTableI)
    if (lidar == c.lidar) return &c;
  return nullptr;
}

/// The paper's Table I figure for `alpha_m` in `column`; NaN when it has none.
inline double PaperTableI(const PaperTableIColumn* column, double alpha_m) {
  constexpr double kNone = std::numeric_limits<double>::quiet_NaN();
  if (!column) return kNone;
  for (size_t i = 0; i < std::size(kPaperAlphasM); ++i)
    if (std::abs(kPaperAlphasM[i] - alpha_m) < 1e-9) return column->px[i];
  return kNone;
}

}  // namespace calibd::bench
