#include "calibd/core/lidar/lidar_model.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <iostream>
#include <set>
#include <vector>

#include "lidar_sim.hpp"

namespace calibd {
namespace {

TEST(LidarModelTest, Ot128Has128RingsFromThePandar128Table) {
  const LidarModel m = MakeLidarModel(LidarKind::kOt128);
  EXPECT_EQ(m.name, "ot128");
  EXPECT_TRUE(m.has_rings);
  ASSERT_EQ(m.ring_elevation_deg.size(), 128u);
  for (double e : m.ring_elevation_deg) {
    EXPECT_GE(e, -25.5);
    EXPECT_LE(e, 15.5);
  }
  // Extremes of the Pandar128E4X channel distribution: channel 1 at the top, 128 at the bottom.
  EXPECT_DOUBLE_EQ(m.ring_elevation_deg.front(), 14.436);
  EXPECT_DOUBLE_EQ(m.ring_elevation_deg.back(), -25.016);
  EXPECT_DOUBLE_EQ(m.elevation_max_deg, 14.436);
  EXPECT_DOUBLE_EQ(m.elevation_min_deg, -25.016);
  EXPECT_DOUBLE_EQ(m.elevation_resolution_deg, 0.125);
  EXPECT_DOUBLE_EQ(m.azimuth_resolution_deg, 0.2);
  EXPECT_DOUBLE_EQ(m.range_quantization_m, 0.004);
  EXPECT_EQ(m.nominal_points_per_frame, 1800 * 128);
}

TEST(LidarModelTest, Ot128RingsAreDistinctAndDescending) {
  const LidarModel m = MakeLidarModel(LidarKind::kOt128);
  const std::set<double> unique(m.ring_elevation_deg.begin(), m.ring_elevation_deg.end());
  EXPECT_EQ(unique.size(), m.ring_elevation_deg.size());
  for (size_t i = 1; i < m.ring_elevation_deg.size(); ++i)
    EXPECT_LT(m.ring_elevation_deg[i], m.ring_elevation_deg[i - 1]) << "ring " << i;
}

TEST(LidarModelTest, Ot128CentralBandHasEighthDegreeSpacing) {
  const LidarModel m = MakeLidarModel(LidarKind::kOt128);
  // The central band spans about +2.0 to -6.1 deg: 64 gaps of 0.125 deg (+- 0.01 per unit).
  int band_gaps = 0;
  for (size_t i = 1; i < m.ring_elevation_deg.size(); ++i) {
    const double hi = m.ring_elevation_deg[i - 1], lo = m.ring_elevation_deg[i];
    if (hi > 2.1 || lo < -6.2) continue;
    EXPECT_NEAR(hi - lo, 0.125, 0.01) << "between " << hi << " and " << lo;
    ++band_gaps;
  }
  EXPECT_EQ(band_gaps, 64);
  // Outside the band the spacing is coarser.
  EXPECT_GT(m.ring_elevation_deg[0] - m.ring_elevation_deg[1], 0.4);
  EXPECT_GT(m.ring_elevation_deg[126] - m.ring_elevation_deg[127], 0.4);
}

TEST(LidarModelTest, MemsModelsAreRinglessWithTheirFieldsOfView) {
  for (LidarKind kind : {LidarKind::kM1, LidarKind::kFalcon}) {
    const LidarModel m = MakeLidarModel(kind);
    SCOPED_TRACE(m.name);
    EXPECT_FALSE(m.has_rings);
    EXPECT_TRUE(m.ring_elevation_deg.empty());
    EXPECT_DOUBLE_EQ(m.azimuth_max_deg - m.azimuth_min_deg, 120.0);
    EXPECT_NEAR(m.elevation_max_deg - m.elevation_min_deg, 25.0, 1.0);
    EXPECT_GT(m.max_range_m, m.min_range_m);
    EXPECT_GT(m.nominal_points_per_frame, 0);
  }
  const LidarModel m1 = MakeLidarModel(LidarKind::kM1);
  EXPECT_DOUBLE_EQ(m1.range_quantization_m, 0.005);
  EXPECT_DOUBLE_EQ(m1.azimuth_resolution_deg, 0.2);
  EXPECT_DOUBLE_EQ(m1.elevation_resolution_deg, 0.2);
  const LidarModel falcon = MakeLidarModel(LidarKind::kFalcon);
  EXPECT_DOUBLE_EQ(falcon.range_quantization_m, 0.0025);
  EXPECT_LT(falcon.elevation_resolution_deg, 0.1);
}

TEST(LidarModelTest, KindFromNameParsesKnownAndRejectsOthers) {
  LidarKind kind = LidarKind::kOt128;
  std::string error;
  ASSERT_TRUE(LidarKindFromName("m1", &kind, &error));
  EXPECT_EQ(kind, LidarKind::kM1);
  ASSERT_TRUE(LidarKindFromName("falcon", &kind, &error));
  EXPECT_EQ(kind, LidarKind::kFalcon);
  ASSERT_TRUE(LidarKindFromName("ot128", &kind, &error));
  EXPECT_EQ(kind, LidarKind::kOt128);
  EXPECT_FALSE(LidarKindFromName("velodyne", &kind, &error));
  EXPECT_NE(error.find("velodyne"), std::string::npos) << error;
}

TEST(LidarModelTest, EveryListedNameParsesToAModelOfThatName) {
  const std::string names = LidarModelNames();
  int count = 0;
  size_t start = 0;
  while (start < names.size()) {
    size_t end = names.find(", ", start);
    if (end == std::string::npos) end = names.size();
    const std::string name = names.substr(start, end - start);
    LidarKind kind;
    std::string error;
    ASSERT_TRUE(LidarKindFromName(name, &kind, &error)) << name << ": " << error;
    EXPECT_EQ(MakeLidarModel(kind).name, name);
    ++count;
    start = end + 2;
  }
  EXPECT_EQ(count, 9);
  EXPECT_EQ(SimulatedLidarKinds().size(), 8u);
  std::string error;
  LidarKind kind;
  EXPECT_FALSE(LidarKindFromName("VLP16", &kind, &error));
  EXPECT_NE(error.find("vlp16"), std::string::npos) << "the error lists the names: " << error;
}

std::vector<double> SortedRings(const LidarModel& m) {
  std::vector<double> r = m.ring_elevation_deg;
  std::sort(r.begin(), r.end());
  return r;
}

TEST(LidarModelTest, Vlp16Has16RingsTwoDegreesApartInFiringOrder) {
  const LidarModel m = MakeLidarModel(LidarKind::kVlp16);
  ASSERT_TRUE(m.has_rings);
  ASSERT_EQ(m.ring_elevation_deg.size(), 16u);
  // Packets list the lasers interleaved: -15, +1, -13, +3, ...
  EXPECT_DOUBLE_EQ(m.ring_elevation_deg[0], -15.0);
  EXPECT_DOUBLE_EQ(m.ring_elevation_deg[1], 1.0);
  EXPECT_DOUBLE_EQ(m.ring_elevation_deg[15], 15.0);
  const std::vector<double> r = SortedRings(m);
  for (int i = 0; i < 16; ++i) EXPECT_DOUBLE_EQ(r[i], -15.0 + 2.0 * i);
  EXPECT_DOUBLE_EQ(m.elevation_resolution_deg, 2.0);
  EXPECT_DOUBLE_EQ(m.azimuth_resolution_deg, 0.2);
  EXPECT_EQ(m.nominal_points_per_frame, 1800 * 16);
}

TEST(LidarModelTest, Vlp32cPacksItsRingsAroundTheHorizon) {
  const LidarModel m = MakeLidarModel(LidarKind::kVlp32c);
  ASSERT_EQ(m.ring_elevation_deg.size(), 32u);
  const std::vector<double> r = SortedRings(m);
  EXPECT_DOUBLE_EQ(r.front(), -25.0);
  EXPECT_DOUBLE_EQ(r.back(), 15.0);
  EXPECT_NEAR(m.elevation_resolution_deg, 0.333, 0.001);
  for (size_t i = 1; i < r.size(); ++i) {
    EXPECT_GT(r[i], r[i - 1]) << "distinct rings";
    if (r[i - 1] >= -4.01 && r[i] <= 1.7) {
      EXPECT_NEAR(r[i] - r[i - 1], 0.333, 0.002);
    }
  }
}

TEST(LidarModelTest, Os1_64HasEvenlySpacedRingsOver45Degrees) {
  const LidarModel m = MakeLidarModel(LidarKind::kOs1_64);
  ASSERT_EQ(m.ring_elevation_deg.size(), 64u);
  const std::vector<double> r = SortedRings(m);
  EXPECT_NEAR(r.front(), -22.5, 1e-9);
  EXPECT_NEAR(r.back(), 22.5, 1e-9);
  for (size_t i = 1; i < r.size(); ++i) EXPECT_NEAR(r[i] - r[i - 1], 45.0 / 63.0, 1e-9);
  EXPECT_NEAR(m.azimuth_resolution_deg, 360.0 / 1024.0, 1e-12);
  EXPECT_EQ(m.nominal_points_per_frame, 1024 * 64);
}

TEST(LidarModelTest, LivoxLikeModelsAreRinglessWithTheirDatasheetFields) {
  const LidarModel avia = MakeLidarModel(LidarKind::kAvia);
  EXPECT_FALSE(avia.has_rings);
  EXPECT_NEAR(avia.azimuth_max_deg - avia.azimuth_min_deg, 70.4, 1e-9);
  EXPECT_NEAR(avia.elevation_max_deg - avia.elevation_min_deg, 77.2, 1e-9);
  EXPECT_EQ(avia.nominal_points_per_frame, 24000);
  const LidarModel mid = MakeLidarModel(LidarKind::kMid360);
  EXPECT_FALSE(mid.has_rings);
  EXPECT_DOUBLE_EQ(mid.azimuth_max_deg - mid.azimuth_min_deg, 360.0);
  EXPECT_DOUBLE_EQ(mid.elevation_min_deg, -7.0);
  EXPECT_DOUBLE_EQ(mid.elevation_max_deg, 52.0);
  EXPECT_EQ(mid.nominal_points_per_frame, 20000);
}

void ExpectPatternInsideModel(const LidarModel& m, const std::vector<sim::Beam>& beams) {
  const double eps = 1e-4;
  const double period_us = 1e6 / m.frame_rate_hz;
  int32_t last_t = 0;
  for (size_t i = 0; i < beams.size(); ++i) {
    const sim::Beam& b = beams[i];
    const double az = b.azimuth_rad * kRad2Deg, el = b.elevation_rad * kRad2Deg;
    ASSERT_GE(az, m.azimuth_min_deg - eps) << "beam " << i;
    ASSERT_LE(az, m.azimuth_max_deg + eps) << "beam " << i;
    ASSERT_GE(el, m.elevation_min_deg - eps) << "beam " << i;
    ASSERT_LE(el, m.elevation_max_deg + eps) << "beam " << i;
    ASSERT_GE(b.time_offset_us, 0);
    ASSERT_LT(b.time_offset_us, period_us);
    if (m.has_rings) {
      ASSERT_GE(b.ring, 0);
      ASSERT_LT(b.ring, static_cast<int>(m.ring_elevation_deg.size()));
    } else {
      ASSERT_EQ(b.ring, -1);
    }
    // Firing order: time never goes back by more than one column's per-ring spread.
    ASSERT_GE(b.time_offset_us, last_t - 60) << "beam " << i;
    last_t = std::max(last_t, b.time_offset_us);
  }
}

TEST(LidarPatternTest, Ot128IsFullCircleOf1800ColumnsOf128Rings) {
  const LidarModel m = MakeLidarModel(LidarKind::kOt128);
  std::vector<sim::Beam> beams;
  sim::MakeScanPattern(m, 0, &beams);
  ASSERT_EQ(beams.size(), 1800u * 128u);
  ExpectPatternInsideModel(m, beams);
  std::set<int> azimuth_steps;
  for (const auto& b : beams)
    azimuth_steps.insert(static_cast<int>(std::lround(b.azimuth_rad * kRad2Deg / 0.2)));
  EXPECT_EQ(azimuth_steps.size(), 1800u);
  for (int ring = 0; ring < 128; ++ring)
    EXPECT_NEAR(beams[ring].elevation_rad * kRad2Deg, m.ring_elevation_deg[ring], 1e-4);
}

TEST(LidarPatternTest, M1HasAbout78kBeamsThatShiftBetweenFrames) {
  const LidarModel m = MakeLidarModel(LidarKind::kM1);
  std::vector<sim::Beam> a, b;
  sim::MakeScanPattern(m, 0, &a);
  sim::MakeScanPattern(m, 1, &b);
  EXPECT_NEAR(static_cast<double>(a.size()), 78000.0, 7800.0);
  EXPECT_EQ(static_cast<int>(a.size()), m.nominal_points_per_frame);
  ExpectPatternInsideModel(m, a);
  ExpectPatternInsideModel(m, b);
  ASSERT_EQ(a.size(), b.size());
  int moved = 0;
  for (size_t i = 0; i < a.size(); ++i)
    if (a[i].azimuth_rad != b[i].azimuth_rad || a[i].elevation_rad != b[i].elevation_rad) ++moved;
  EXPECT_GT(moved, static_cast<int>(a.size()) / 2);
  // Deterministic.
  std::vector<sim::Beam> again;
  sim::MakeScanPattern(m, 0, &again);
  for (size_t i = 0; i < a.size(); ++i) ASSERT_EQ(a[i].azimuth_rad, again[i].azimuth_rad);
}

TEST(LidarPatternTest, M1FiresFiveZonesInParallelWithSinusoidalFastAxis) {
  const LidarModel m = MakeLidarModel(LidarKind::kM1);
  std::vector<sim::Beam> beams;
  sim::MakeScanPattern(m, 0, &beams);
  // Consecutive groups of 5 beams share a firing time and sit in 5 distinct 24-deg zones.
  for (size_t g = 0; g + 5 <= beams.size(); g += 5 * 997) {
    std::set<int> zones;
    for (size_t k = 0; k < 5; ++k) {
      EXPECT_EQ(beams[g + k].time_offset_us, beams[g].time_offset_us);
      zones.insert(static_cast<int>(std::floor((beams[g + k].azimuth_rad * kRad2Deg + 60) / 24)));
    }
    EXPECT_EQ(zones.size(), 5u);
  }
  // Sinusoidal sweep: azimuth steps are smaller near the zone edges than at its centre.
  const double edge_step = std::abs(beams[5].azimuth_rad - beams[0].azimuth_rad);
  const double mid_step = std::abs(beams[5 * 63].azimuth_rad - beams[5 * 62].azimuth_rad);
  EXPECT_LT(edge_step * 3.0, mid_step);
}

TEST(LidarPatternTest, FalconHasDenseCentralBandAndDocumentedSize) {
  const LidarModel m = MakeLidarModel(LidarKind::kFalcon);
  std::vector<sim::Beam> beams;
  sim::MakeScanPattern(m, 0, &beams);
  EXPECT_EQ(static_cast<int>(beams.size()), m.nominal_points_per_frame);
  EXPECT_GE(beams.size(), 100000u);
  EXPECT_LE(beams.size(), 150000u);
  ExpectPatternInsideModel(m, beams);
  std::set<double> lines;
  for (const auto& b : beams) lines.insert(std::round(b.elevation_rad * kRad2Deg * 1e4) / 1e4);
  std::vector<double> el(lines.begin(), lines.end());
  double band_gap = 0.0, outer_gap = 0.0;
  for (size_t i = 1; i < el.size(); ++i) {
    const double mid = 0.5 * (el[i] + el[i - 1]), gap = el[i] - el[i - 1];
    if (std::abs(mid) < 2.0) band_gap = std::max(band_gap, gap);
    if (std::abs(mid) > 5.0) outer_gap = std::max(outer_gap, gap);
  }
  EXPECT_LE(band_gap, 0.1);
  EXPECT_GE(outer_gap, 0.15);
  // Polygon sweep: linear in time, so the first line's azimuth steps are equal.
  const double s0 = beams[1].azimuth_rad - beams[0].azimuth_rad;
  const double s1 = beams[400].azimuth_rad - beams[399].azimuth_rad;
  EXPECT_NEAR(s0, s1, 1e-6);
  EXPECT_GT(s0, 0.0);
}

TEST(LidarPatternTest, SpinningModelsFireEveryRingInEveryColumn) {
  for (LidarKind kind : {LidarKind::kVlp16, LidarKind::kVlp32c, LidarKind::kOs1_64}) {
    const LidarModel m = MakeLidarModel(kind);
    SCOPED_TRACE(m.name);
    std::vector<sim::Beam> beams;
    sim::MakeScanPattern(m, 0, &beams);
    ASSERT_EQ(static_cast<int>(beams.size()), m.nominal_points_per_frame);
    ExpectPatternInsideModel(m, beams);
    const size_t rings = m.ring_elevation_deg.size();
    for (size_t ring = 0; ring < rings; ++ring)
      EXPECT_NEAR(beams[rings + ring].elevation_rad * kRad2Deg, m.ring_elevation_deg[ring], 1e-4);
  }
}

// Fraction of the 0.4 deg cells inside the central half of the field that `frames` frames hit.
double CentralCoverage(const LidarModel& m, int frames) {
  const double half_az = 0.25 * (m.azimuth_max_deg - m.azimuth_min_deg);
  const double mid_el = 0.5 * (m.elevation_max_deg + m.elevation_min_deg);
  const double half_el = 0.25 * (m.elevation_max_deg - m.elevation_min_deg);
  const int cols = static_cast<int>(2 * half_az / 0.4), rows = static_cast<int>(2 * half_el / 0.4);
  std::vector<char> hit(static_cast<size_t>(cols) * rows, 0);
  std::vector<sim::Beam> beams;
  for (int f = 0; f < frames; ++f) {
    sim::MakeScanPattern(m, f, &beams);
    for (const sim::Beam& b : beams) {
      const int c = static_cast<int>(std::floor((b.azimuth_rad * kRad2Deg + half_az) / 0.4));
      const int r =
          static_cast<int>(std::floor((b.elevation_rad * kRad2Deg - mid_el + half_el) / 0.4));
      if (c >= 0 && c < cols && r >= 0 && r < rows) hit[static_cast<size_t>(r) * cols + c] = 1;
    }
  }
  return static_cast<double>(std::count(hit.begin(), hit.end(), 1)) /
         static_cast<double>(hit.size());
}

TEST(LidarPatternTest, LivoxLikePatternsNeverRepeatAndFillTheFieldOverFrames) {
  for (LidarKind kind : {LidarKind::kAvia, LidarKind::kMid360}) {
    const LidarModel m = MakeLidarModel(kind);
    SCOPED_TRACE(m.name);
    std::vector<sim::Beam> a, b;
    sim::MakeScanPattern(m, 0, &a);
    sim::MakeScanPattern(m, 1, &b);
    ASSERT_EQ(static_cast<int>(a.size()), m.nominal_points_per_frame);
    ExpectPatternInsideModel(m, a);
    ExpectPatternInsideModel(m, b);
    int moved = 0;
    for (size_t i = 0; i < a.size(); ++i)
      moved += std::abs(a[i].azimuth_rad - b[i].azimuth_rad) +
                           std::abs(a[i].elevation_rad - b[i].elevation_rad) >
                       1e-4
                   ? 1
                   : 0;
    EXPECT_GT(moved, static_cast<int>(a.size()) * 9 / 10);
    const double one = CentralCoverage(m, 1), ten = CentralCoverage(m, 10);
    std::cout << m.name << ": 0.4 deg cells of the central field hit by 1 frame " << one
              << ", by 10 frames " << ten << "\n";
    EXPECT_GT(ten, 1.5 * one);
  }
}

}  // namespace
}  // namespace calibd
