#include "calibd/core/lidar_model.hpp"

namespace calibd {

bool LidarKindFromName(const std::string& name, LidarKind* kind, std::string* error) {
  if (name == "ot128")
    *kind = LidarKind::kOt128;
  else if (name == "m1")
    *kind = LidarKind::kM1;
  else if (name == "falcon")
    *kind = LidarKind::kFalcon;
  else {
    if (error) *error = "unknown LiDAR model '" + name + "' (expected ot128, m1 or falcon)";
    return false;
  }
  return true;
}

// PLACEHOLDER: replaced by the full tables (being written).
LidarModel MakeLidarModel(LidarKind kind) {
  LidarModel m;
  m.kind = kind;
  m.name = kind == LidarKind::kOt128 ? "ot128" : kind == LidarKind::kM1 ? "m1" : "falcon";
  return m;
}

}  // namespace calibd
