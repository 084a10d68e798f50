#include "calibd/core/verdict/verdict.hpp"

namespace calibd {

namespace {

// The order matters where one fault shows in several figures: the gate that names the cause comes
// first. A bent board also shows as a range offset, a scale, a lens misfit or scatter; a wrong
// scale also spreads the boards' distances, and so the time offset's sigma.
constexpr Gate kGates[] = {
    CheckBoardFlatness,          // board_flatness_gate.hpp
    CheckPlaneConditioning,      // precision_gate.hpp
    CheckFormalSigmas,           //
    CheckLensModel,              // principal_point_gate.hpp
    CheckPrincipalPoint,         //
    CheckStatedPrincipalPoint,   //
    CheckCameraScale,            // camera_scale_gate.hpp
    CheckRangeOffset,            // range_offset_gate.hpp
    CheckRingElevations,         // ring_elevation_gate.hpp
    CheckRangeOffsetObservable,  // range_offset_gate.hpp
    CheckScaleObservable,        // camera_scale_gate.hpp
    CheckTimeOffset,             // time_offset_gate.hpp
    CheckHalfDataSpread,         // stability_gate.hpp
    CheckStartChecks,            //
    CheckReprojection,           // reprojection_gate.hpp
    CheckResidual,               // residual_gate.hpp
    CheckErrorBound,             // error_bound_gate.hpp
    CheckDeltaFromPrior,         // prior_tolerance_gate.hpp
};

}  // namespace

Reason FailedGate(const GateInput& in, std::string* detail) {
  for (const Gate gate : kGates)
    if (const Reason reason = gate(in, detail); reason != Reason::kNone) return reason;
  return Reason::kNone;
}

}  // namespace calibd
