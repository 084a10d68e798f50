#pragma once
/// \file
/// The simulator's ground-truth file (--truth): true and prior extrinsic, intrinsics, mounts, board
/// poses per frame and the indices of the LiDAR points that hit each board. For evaluation only:
/// the calibration pipeline never reads it.

#include <nlohmann/json.hpp>
#include <string>

#include "session.hpp"

namespace calibd::sim {

/// Accumulates per-frame truth and writes the JSON document.
class TruthWriter {
 public:
  explicit TruthWriter(const SessionSimulator& session);
  void AddFrame(const FrameTruth& frame, int num_lidar_points);
  /// Writes atomically (temp file + rename); false with `error` naming the path.
  bool Save(const std::string& path, std::string* error) const;
  const nlohmann::json& document() const { return doc_; }

 private:
  nlohmann::json doc_;
};

/// 4x4 row-major nested array, and back.
nlohmann::json PoseToJson(const Pose& T);
Pose PoseFromJson(const nlohmann::json& j);

}  // namespace calibd::sim
