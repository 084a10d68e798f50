#pragma once
/// \file
/// One check of a solved session's verdict: what every gate reads and how it answers. Each gate
/// has a file of its own under verdict/gates/ with its settings and constants beside it;
/// verdict.hpp lists them in the order they are asked.

#include <string>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/verdict/quality_figures.hpp"
#include "calibd/core/verdict/reason.hpp"

namespace calibd {

struct VerdictConfig;  // verdict.hpp: every gate's settings

/// A solved session as the gates see it.
struct GateInput {
  const CameraIntrinsics& camera;
  const VerdictConfig& config;
  const QualityFigures& quality;
  /// The solution's change from the prior calibration.
  double delta_rotation_deg = 0.0, delta_translation_m = 0.0;
};

/// A gate: Reason::kNone when the session passes it, else the reason with `detail` giving its
/// figures and what the user can do.
using Gate = Reason (*)(const GateInput& in, std::string* detail);

/// `return Refuse(detail, Reason::kX, "...")` in a gate.
inline Reason Refuse(std::string* detail, Reason reason, std::string text) {
  *detail = std::move(text);
  return reason;
}

}  // namespace calibd
