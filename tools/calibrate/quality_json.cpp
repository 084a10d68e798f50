#include "quality_json.hpp"

#include <cmath>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

nlohmann::json QualityJson(const QualityFigures& q) {
  nlohmann::json j = {{"reprojection_mean_px", q.reprojection_mean_px},
                      {"reprojection_p95_px", q.reprojection_p95_px},
                      {"reprojection_median_px", q.reprojection_median_px},
                      {"reprojection_gate_px", q.reprojection_gate_px},
                      {"lidar_spacing_px", q.lidar_spacing_px},
                      {"residual_rms_m", q.residual_rms_m},
                      {"frames_used", q.frames_used},
                      {"boards_used", q.boards_used},
                      {"distance_min_m", q.min_distance_m},
                      {"distance_max_m", q.max_distance_m},
                      {"image_coverage", q.image_coverage},
                      {"min_information_eigenvalue", q.min_information_eigenvalue},
                      {"rotation_sigma_deg", q.rotation_sigma_deg},
                      {"translation_sigma_m", q.translation_sigma_m},
                      {"plane_conditioning", q.plane_conditioning},
                      {"rotation_spread_deg", q.rotation_spread_deg},
                      {"translation_spread_m", q.translation_spread_m},
                      {"start_rotation_deg", q.start_rotation_deg},
                      {"start_translation_m", q.start_translation_m},
                      {"camera_scale_error", q.camera_scale_error},
                      {"camera_scale_sigma", q.camera_scale_sigma},
                      {"camera_scale_corrected", q.camera_scale_corrected},
                      {"camera_scale_translation_m", q.camera_scale_translation_m},
                      {"lidar_range_offset_m", q.lidar_range_offset_m},
                      {"lidar_range_offset_sigma_m", q.lidar_range_offset_sigma_m},
                      {"board_normal_speed_mps", q.board_normal_speed_mps}};
  // Not fitted (no moving boards, or no capture times): null, not a made-up zero.
  nlohmann::json offset = nullptr, sigma = nullptr;
  if (q.time_offset_fitted) {
    offset = q.time_offset_s;
    if (std::isfinite(q.time_offset_sigma_s)) sigma = q.time_offset_sigma_s;
  }
  j["time_offset_s"] = offset;
  j["time_offset_sigma_s"] = sigma;
  j["time_offset_corrected_s"] = q.time_offset_corrected_s;
  // How far an offset as large as its sigma moves the translation (the boards' normal speed
  // times it): what a session that cannot measure the offset rests on the stamps for.
  j["time_offset_translation_m"] =
      sigma.is_null() ? nullptr : nlohmann::json(q.time_offset_sigma_s * q.board_normal_speed_mps);
  nlohmann::json shift = nullptr, shift_sigma = nullptr, shift_systematic = nullptr;
  if (q.principal_point_fitted) {
    shift = {q.principal_point_shift_px.x(), q.principal_point_shift_px.y()};
    shift_sigma = {q.principal_point_sigma_px.x(), q.principal_point_sigma_px.y()};
    shift_systematic = {q.principal_point_systematic_px.x(), q.principal_point_systematic_px.y()};
  }
  j["principal_point_shift_px"] = shift;
  j["principal_point_sigma_px"] = shift_sigma;
  j["principal_point_systematic_px"] = shift_systematic;
  j["principal_point_residual_px"] = q.principal_point_residual_px;
  j["ring_elevation_rings"] = q.ring_elevation_rings;
  j["ring_elevation_rms_deg"] = q.ring_elevation_rms_deg;
  j["ring_elevation_chi2"] = q.ring_elevation_chi2;
  j["board_bend_id"] = q.board_bend_id;
  j["board_bend_m"] = q.board_bend_id >= 0 ? nlohmann::json(q.board_bend_m) : nullptr;
  j["board_bend_sigma_m"] = q.board_bend_id >= 0 ? nlohmann::json(q.board_bend_sigma_m) : nullptr;
  // Where the camera sees the board's centre about its tag (board_centre_offset.hpp); an axis
  // it could not measure is null.
  j["board_centre_offset_id"] = q.board_centre_offset_id;
  nlohmann::json centre = nullptr, centre_sigma = nullptr;
  if (q.board_centre_offset_id >= 0) {
    centre = nlohmann::json::array();
    centre_sigma = nlohmann::json::array();
    for (int a = 0; a < 2; ++a) {
      const bool seen = std::isfinite(q.board_centre_offset_sigma_m(a));
      centre.push_back(seen ? nlohmann::json(q.board_centre_offset_m(a)) : nullptr);
      centre_sigma.push_back(seen ? nlohmann::json(q.board_centre_offset_sigma_m(a)) : nullptr);
    }
  }
  j["board_centre_offset_m"] = centre;
  j["board_centre_offset_sigma_m"] = centre_sigma;
  j["principal_point_turn_deg"] = q.principal_point_turn_deg;
  j["principal_point_turn_sigma_deg"] =
      q.principal_point_fitted ? nlohmann::json(q.principal_point_turn_sigma_deg) : nullptr;
  j["principal_point_stated_sigma_px"] = q.principal_point_stated_sigma_px;
  j["principal_point_stated_chi2"] = q.principal_point_stated_chi2;
  j["principal_point_belief_turn_deg"] = q.principal_point_belief.turn_deg;
  const double belief_turn_sigma_deg =
      std::hypot(q.principal_point_belief.sigma_rad.x(), q.principal_point_belief.sigma_rad.y()) *
      kRad2Deg;
  j["principal_point_belief_turn_sigma_deg"] =
      std::isfinite(belief_turn_sigma_deg) ? nlohmann::json(belief_turn_sigma_deg) : nullptr;
  // Which reading of the tags' corners the bound took (CornerBias): "biased" when their blind
  // spot joined their variance, "unbiased" when they alone weighed more.
  j["principal_point_bound_corners"] = CornerBiasName(q.principal_point_bound_corners);
  j["principal_point_ms"] = q.principal_point_ms;
  // The predicted 99 % bound on the result's own error and its parts (ErrorBound); null where
  // the clustered covariance could not be estimated.
  const auto finite = [](double x) { return std::isfinite(x) ? nlohmann::json(x) : nullptr; };
  j["rotation_clustered_sigma_deg"] = finite(q.rotation_clustered_sigma_deg);
  j["translation_clustered_sigma_m"] = finite(q.translation_clustered_sigma_m);
  j["rotation_systematic_deg"] = finite(q.rotation_systematic_deg);
  j["translation_systematic_m"] = q.translation_systematic_m;
  j["translation_bound_range_offset_m"] = q.translation_bound_range_offset_m;
  j["translation_bound_scale_m"] = q.translation_bound_scale_m;
  j["translation_bound_time_offset_m"] = q.translation_bound_time_offset_m;
  j["translation_bound_principal_point_m"] = q.translation_bound_principal_point_m;
  j["translation_bound_board_centre_m"] = q.translation_bound_board_centre_m;
  j["rotation_bound_time_offset_deg"] = q.rotation_bound_time_offset_deg;
  j["rotation_bound_camera_scale_deg"] = q.rotation_bound_camera_scale_deg;
  j["rotation_bound_deg"] = finite(q.rotation_bound_deg);
  j["translation_bound_m"] = finite(q.translation_bound_m);
  return j;
}

}  // namespace calibd
