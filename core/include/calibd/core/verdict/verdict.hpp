#pragma once
/// \file
/// The verdict on a solved session: its gates in order (the first that fails gives the reason)
/// and their settings, the config section `engine.verdict`. A new gate is a file under
/// verdict/gates/ and a line in the list of gates (verdict.cpp), its settings a base of
/// VerdictConfig below.
///
/// Verdicts: `verified` (the new estimate agrees with the prior within the verification
/// tolerance: the prior is kept), `updated` (a plausible change and every gate passes),
/// `rejected` with a Reason (reason.hpp, which says what each one means; the operator guide's
/// troubleshooting table says what to do).

#include <string>

#include "calibd/core/verdict/gate.hpp"
#include "calibd/core/verdict/gates/board_flatness_gate.hpp"
#include "calibd/core/verdict/gates/camera_scale_gate.hpp"
#include "calibd/core/verdict/gates/correspondence_count_gate.hpp"
#include "calibd/core/verdict/gates/error_bound_gate.hpp"
#include "calibd/core/verdict/gates/precision_gate.hpp"
#include "calibd/core/verdict/gates/principal_point_gate.hpp"
#include "calibd/core/verdict/gates/prior_tolerance_gate.hpp"
#include "calibd/core/verdict/gates/range_offset_gate.hpp"
#include "calibd/core/verdict/gates/reprojection_gate.hpp"
#include "calibd/core/verdict/gates/residual_gate.hpp"
#include "calibd/core/verdict/gates/ring_elevation_gate.hpp"
#include "calibd/core/verdict/gates/stability_gate.hpp"
#include "calibd/core/verdict/gates/time_offset_gate.hpp"

namespace calibd {

/// Every gate's settings, each declared beside its gate, read from one config section.
struct VerdictConfig : PriorToleranceConfig,
                       CorrespondenceCountConfig,
                       PrecisionGateConfig,
                       CameraScaleGateConfig,
                       RangeOffsetGateConfig,
                       TimeOffsetGateConfig,
                       StabilityGateConfig,
                       ReprojectionGateConfig,
                       ResidualGateConfig,
                       ErrorBoundGateConfig {};

/// The gates in order: the first that fails gives the reason (`detail` its figures and what to
/// do); kNone when every gate passes.
Reason FailedGate(const GateInput& in, std::string* detail);

}  // namespace calibd
