#include "truth_json.hpp"

#include <cmath>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd::sim {

nlohmann::json PoseToJson(const Pose& T) {
  nlohmann::json rows = nlohmann::json::array();
  for (int r = 0; r < 4; ++r) {
    rows.push_back({T.matrix()(r, 0), T.matrix()(r, 1), T.matrix()(r, 2), T.matrix()(r, 3)});
  }
  return rows;
}

Pose PoseFromJson(const nlohmann::json& j) {
  Pose T = Pose::Identity();
  for (int r = 0; r < 3; ++r)
    for (int c = 0; c < 4; ++c) T.matrix()(r, c) = j.at(r).at(c).get<double>();
  return T;
}

TruthWriter::TruthWriter(const SessionSimulator& s) {
  const auto& o = s.options();
  const auto& cam = o.camera;
  doc_["format"] = "calibd-sim-truth/1";
  doc_["seed"] = o.seed;
  doc_["lidar_model"] = o.lidar_model;
  doc_["camera_id"] = o.camera_id;
  doc_["lidar_id"] = o.lidar_id;
  doc_["T_camera_lidar"] = PoseToJson(s.T_camera_lidar());
  doc_["prior_T_camera_lidar"] = PoseToJson(s.prior_T_camera_lidar());
  const Pose delta = s.prior_T_camera_lidar().inverse() * s.T_camera_lidar();
  doc_["prior_rotation_error_deg"] =
      RotationAngle(s.prior_T_camera_lidar().linear(), s.T_camera_lidar().linear()) * 180.0 / M_PI;
  doc_["prior_translation_error_m"] =
      (s.prior_T_camera_lidar().translation() - s.T_camera_lidar().translation()).norm();
  doc_["prior_delta_T"] = PoseToJson(delta);
  doc_["T_vehicle_lidar"] = PoseToJson(s.T_vehicle_lidar());
  doc_["T_vehicle_camera"] = PoseToJson(s.T_vehicle_camera());
  doc_["camera_phase_us"] = s.camera_phase_us();
  doc_["intrinsics"] = {{"width", cam.width},
                        {"height", cam.height},
                        {"fx", cam.fx},
                        {"fy", cam.fy},
                        {"cx", cam.cx},
                        {"cy", cam.cy},
                        {"distortion", {cam.k1, cam.k2, cam.p1, cam.p2, cam.k3}}};
  doc_["lidar_noise"] = {{"range_sigma_m", o.lidar_noise.range_sigma_m},
                         {"angular_jitter_deg", o.lidar_noise.angular_jitter_deg},
                         {"dropout_probability", o.lidar_noise.dropout_probability},
                         {"beam_divergence_mrad", o.lidar_noise.beam_divergence_mrad},
                         {"range_bias_m", o.lidar_noise.range_bias_m}};
  doc_["camera_delay_us"] = o.camera_delay_us;
  nlohmann::json boards = nlohmann::json::array();
  const auto& w = s.workshop();
  for (size_t b = 0; b < w.scene.boards.size(); ++b) {
    const auto& g = w.geometries[b];
    boards.push_back({{"board_id", g.board_id},
                      {"tag_family", g.tag_family},
                      {"tag_id", g.tag_id},
                      {"width_m", g.width_m},
                      {"height_m", g.height_m},
                      {"tag_size_m", g.tag_size_m},
                      {"T_world_board", PoseToJson(w.scene.boards[b].T_world_board)}});
  }
  doc_["boards"] = boards;
  doc_["frames"] = nlohmann::json::array();
}

void TruthWriter::AddFrame(const FrameTruth& f, int num_lidar_points) {
  nlohmann::json boards = nlohmann::json::array();
  for (const auto& b : f.boards) {
    boards.push_back({{"board_id", b.board_id},
                      {"T_camera_board", PoseToJson(b.T_camera_board)},
                      {"T_lidar_board", PoseToJson(b.T_lidar_board)},
                      {"tag_in_image", b.tag_in_image},
                      {"lidar_point_indices", b.lidar_point_indices}});
  }
  doc_["frames"].push_back({{"index", f.index},
                            {"camera_utime", f.camera_utime},
                            {"lidar_utime", f.lidar_utime},
                            {"num_lidar_points", num_lidar_points},
                            {"T_world_vehicle", PoseToJson(f.T_world_vehicle)},
                            {"boards", boards}});
}

bool TruthWriter::Save(const std::string& path, std::string* error) const {
  return WriteFileAtomic(path, doc_.dump(1) + "\n", error);
}

}  // namespace calibd::sim
