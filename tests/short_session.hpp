#pragma once
// The error bound's tolerances for tests whose sessions are short: tens of frame pairs of boards
// ahead at up to 30 m bound their translation to 3-8 cm at 99 % (the tags' scale at those
// distances, and a LiDAR range offset that boards ahead cannot tell from the position along
// them), beyond the default 3 cm; a small camera's drive (960x480, 3-8 m) bounds its rotation to
// 0.25-0.45 deg (the tags' scale, which they measure to +-0.05-0.1 %, turns such a drive's result
// by about 1 deg per %), beyond the default 0.3 deg. Tests of other things than that bound accept
// up to these; the bound itself is tested on sessions that meet the defaults (VerdictsBenchTest,
// the verdict's gates in test_verdict.cpp).

#include <string>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd::testing {

inline constexpr double kShortSessionTranslationBoundM = 0.10;
inline constexpr double kShortSessionRotationBoundDeg = 0.6;

/// The engine's defaults with those tolerances.
inline EngineConfig ShortSessionEngine() {
  EngineConfig engine;
  engine.verdict.max_translation_bound_m = kShortSessionTranslationBoundM;
  engine.verdict.max_rotation_bound_deg = kShortSessionRotationBoundDeg;
  return engine;
}

/// The same as a config file's section.
inline std::string ShortSessionEngineYaml() {
  return "engine:\n  verdict:\n    max_translation_bound_m: " +
         std::to_string(kShortSessionTranslationBoundM) +
         "\n    max_rotation_bound_deg: " + std::to_string(kShortSessionRotationBoundDeg) + "\n";
}

}  // namespace calibd::testing
