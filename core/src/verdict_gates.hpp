#pragma once
// Private to the engine: the verdict's gates over a solution's quality figures
// (calibration_engine.hpp documents each reason), and the start checks' distance that one of them
// words.

#include <string>

#include "calibd/core/calibration_engine.hpp"

namespace calibd::detail {

// How far the start checks (EngineConfig::start_checks) start from the solution: two grid-search
// steps and a mounting tolerance's worth, within the optimiser's basin when the data leave one.
inline constexpr double kStartCheckRotationDeg = 3.0;
inline constexpr double kStartCheckTranslationM = 0.05;

// The gates in order: the first that fails gives the reason (`detail` its figures and what to
// do); kNone when every gate passes.
Reason FailedGate(const CameraIntrinsics& camera, const VerdictConfig& v,
                  const CalibrationOutcome& out, std::string* detail);

}  // namespace calibd::detail
