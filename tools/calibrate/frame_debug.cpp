#include "frame_debug.hpp"

#include <cstdio>
#include <nlohmann/json.hpp>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd::tools {

namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

}  // namespace

std::string FrameDebugJson(const FrameDebugInput& in) {
  nlohmann::json j;
  j["pair"] = in.pair_index;
  j["camera_utime"] = in.camera_utime;
  j["lidar_utime"] = in.lidar_utime;
  nlohmann::json camera;
  camera["full_frame_search"] = in.camera->full_frame_search;
  camera["rejected_candidates"] = in.camera->rejected;
  camera["boards"] = nlohmann::json::array();
  for (const BoardDetection2D& b : in.camera->boards) {
    nlohmann::json corners = nlohmann::json::array();
    for (const auto& c : b.corners_px) corners.push_back({c.x(), c.y()});
    camera["boards"].push_back({{"board_id", b.board_id},
                                {"corners_px", corners},
                                {"distance_m", b.T_camera_board.translation().norm()},
                                {"reprojection_rms_px", b.reprojection_rms_px},
                                {"decision_margin", b.decision_margin}});
  }
  j["camera"] = camera;
  nlohmann::json lidar;
  lidar["points"] = in.lidar_points;
  lidar["invalid_points"] = in.lidar->invalid_points;
  lidar["outside_points"] = in.lidar->outside_points;
  lidar["segments"] = in.lidar->num_clusters;
  lidar["boards"] = in.lidar->boards.size();
  lidar["clusters"] = nlohmann::json::array();
  for (const LidarClusterReport& r : in.lidar->clusters) {
    lidar["clusters"].push_back({{"gate", ClusterGateName(r.gate)},
                                 {"segment", r.segment},
                                 {"plane", r.plane},
                                 {"cells", r.num_points},
                                 {"centroid_m", Vec(r.centroid)},
                                 {"range_m", r.centroid.norm()},
                                 {"rectangle_m", {r.rectangle(0), r.rectangle(1)}},
                                 {"rms_size_m", r.size_m},
                                 {"planarity", r.planarity},
                                 {"tilt_deg", r.tilt_deg},
                                 {"attached_fraction", r.attached_fraction},
                                 {"descriptor_score", r.score}});
  }
  j["lidar"] = lidar;
  return j.dump(1) + "\n";
}

bool WriteFrameDebug(const std::string& dir, const FrameDebugInput& in, std::string* error) {
  char name[32];
  std::snprintf(name, sizeof(name), "/pair_%06d.json", in.pair_index);
  return WriteFileAtomic(dir + name, FrameDebugJson(in), error);
}

}  // namespace calibd::tools
