#pragma once
// The error bound's translation tolerance for tests whose sessions are short: tens of frame
// pairs of boards ahead at up to 30 m bound their translation to 3-8 cm at 99 % (the tags'
// scale at those distances, and a LiDAR range offset that boards ahead cannot tell from the
// position along them), beyond the default 3 cm. Tests of other things than that bound accept
// up to this; the bound itself is tested on sessions that meet the default (VerdictsBenchTest,
// the verdict's gates in test_verdict.cpp).

#include <string>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd::testing {

inline constexpr double kShortSessionTranslationBoundM = 0.10;

/// The engine's defaults with that tolerance.
inline EngineConfig ShortSessionEngine() {
  EngineConfig engine;
  engine.verdict.max_translation_bound_m = kShortSessionTranslationBoundM;
  return engine;
}

/// The same as a config file's section.
inline std::string ShortSessionEngineYaml() {
  return "engine:\n  verdict:\n    max_translation_bound_m: " +
         std::to_string(kShortSessionTranslationBoundM) + "\n";
}

}  // namespace calibd::testing
