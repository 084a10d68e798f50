#include "calibd/core/config.hpp"

#include <cmath>
#include <set>

#include "calibd/core/lidar_model.hpp"

namespace calibd {

bool CalibConfig::IsValid(std::string* error) const {
  std::string why;
  auto fail = [&](const std::string& key, const std::string& what) {
    if (error) *error = key + ": " + what;
    return false;
  };
  if (camera_id.empty()) return fail("camera.id", "must not be empty");
  if (!camera.IsValid(&why)) return fail("camera.intrinsics", why);
  if (lidar_id.empty()) return fail("lidar.id", "must not be empty");
  LidarKind kind;
  if (!LidarKindFromName(lidar_model, &kind, &why)) return fail("lidar.model", why);
  if (boards.empty()) return fail("boards", "at least one board is required");
  std::set<int> ids, tags;
  for (size_t i = 0; i < boards.size(); ++i) {
    const std::string key = "boards[" + std::to_string(i) + "]";
    if (!boards[i].IsValid(&why)) return fail(key, why);
    if (!ids.insert(boards[i].board_id).second) return fail(key + ".id", "duplicate board id");
    if (!tags.insert(boards[i].tag_id).second) return fail(key + ".tag_id", "duplicate tag id");
  }
  const Eigen::Matrix3d R = prior_T_camera_lidar.linear();
  if (!prior_T_camera_lidar.matrix().allFinite() ||
      !(R.transpose() * R).isApprox(Eigen::Matrix3d::Identity(), 1e-6) || !(R.determinant() > 0.0))
    return fail("prior.T_camera_lidar", "rotation part is not a proper rotation");
  return true;
}

}  // namespace calibd
