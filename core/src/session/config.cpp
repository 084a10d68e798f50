#include "calibd/core/session/config.hpp"

#include <cmath>
#include <set>

#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {

namespace {

// A frame id every export can carry unquoted: a ROS command-line argument, a YAML key, a tf2
// frame (which rejects a leading '/').
bool FrameIdValid(const std::string& id, std::string* why) {
  if (id.empty()) {
    *why = "must not be empty";
    return false;
  }
  if (id.size() > 64) {
    *why = "must be at most 64 characters (got " + std::to_string(id.size()) + ")";
    return false;
  }
  if (id.front() == '/') {
    *why = "must not start with '/' (tf2 rejects it; got '" + id + "')";
    return false;
  }
  for (const char ch : id) {
    const bool ok = (ch >= 'a' && ch <= 'z') || (ch >= 'A' && ch <= 'Z') ||
                    (ch >= '0' && ch <= '9') || ch == '_' || ch == '-' || ch == '.' || ch == '/';
    if (!ok) {
      *why = "may hold only letters, digits and _ - . / (got '" + id + "')";
      return false;
    }
  }
  return true;
}

}  // namespace

bool CalibConfig::IsValid(std::string* error) const {
  std::string why;
  auto fail = [&](const std::string& key, const std::string& what) {
    if (error) *error = key + ": " + what;
    return false;
  };
  if (camera_id.empty()) return fail("camera.id", "must not be empty");
  if (!camera.IsValid(&why)) return fail("camera.intrinsics", why);
  if (!(principal_point_sigma_px >= 0.0 && std::isfinite(principal_point_sigma_px)))
    return fail("camera.principal_point_sigma_px", "must be 0 (not stated) or a positive number");
  if (lidar_id.empty()) return fail("lidar.id", "must not be empty");
  if (!FrameIdValid(camera_frame, &why)) return fail("camera.frame_id", why);
  if (!FrameIdValid(lidar_frame, &why)) return fail("lidar.frame_id", why);
  if (camera_frame == lidar_frame)
    return fail("lidar.frame_id", "must differ from camera.frame_id ('" + camera_frame + "')");
  LidarKind kind;
  if (!LidarKindFromName(lidar_model, &kind, &why)) return fail("lidar.model", why);
  if (kind == LidarKind::kGeneric && !lidar_generic.IsValid(&why)) {
    if (error) *error = why;  // already names its lidar.generic key
    return false;
  }
  if (boards.empty()) return fail("boards", "at least one board is required");
  std::set<int> ids, tags;
  for (size_t i = 0; i < boards.size(); ++i) {
    const std::string key = "boards[" + std::to_string(i) + "]";
    if (!boards[i].IsValid(&why)) return fail(key, why);
    if (!ids.insert(boards[i].board_id).second) return fail(key + ".id", "duplicate board id");
    // A checkerboard carries no tag: its tag_id (unwritten, 0) is not an identity.
    if (boards[i].pattern == BoardGeometry::PatternKind::kAprilTag &&
        !tags.insert(boards[i].tag_id).second)
      return fail(key + ".tag_id", "duplicate tag id");
  }
  const Eigen::Matrix3d R = prior_T_camera_lidar.linear();
  if (!prior_T_camera_lidar.matrix().allFinite() ||
      !(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || !(R.determinant() > 0.0))
    return fail("prior.T_camera_lidar", "rotation part is not a proper rotation");
  return true;
}

}  // namespace calibd
