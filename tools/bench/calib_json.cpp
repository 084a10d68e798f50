#include "calib_json.hpp"

#include <cmath>

#include "paper_figures.hpp"

namespace calibd::bench {

namespace {

nlohmann::json Optional(bool present, double v) {
  return present && std::isfinite(v) ? nlohmann::json(v) : nlohmann::json(nullptr);
}

nlohmann::json RunJson(const ScoredRun& r) {
  const bool e = r.has_estimate;
  return {{"verdict", r.verdict},
          {"reason", r.reason},
          {"detail", r.detail},
          {"has_estimate", e},
          {"rotation_error_deg", Optional(e, r.rotation_error_deg)},
          {"translation_error_m", Optional(e, r.translation_error_m)},
          {"error_rpy_deg",
           {Optional(e, r.error_rpy_deg.x()), Optional(e, r.error_rpy_deg.y()),
            Optional(e, r.error_rpy_deg.z())}},
          {"reprojection_mean_px", Optional(e, r.reprojection_mean_px)},
          {"grid_ms", r.grid_ms},
          {"optimise_ms", r.optimise_ms},
          {"frames", r.frames},
          {"camera_boards", r.camera_boards},
          {"boards_used", r.boards_used}};
}

nlohmann::json RunsJson(const std::vector<ScoredRun>& runs) {
  const Summary s = Summarise(runs);
  const bool e = s.estimates > 0;
  nlohmann::json j = {{"complete", s.complete()},
                      {"runs", s.runs},
                      {"estimates", s.estimates},
                      {"missing_reason", s.missing_reason},
                      {"gated", s.gated},
                      {"gate_reason", s.gate_reason},
                      {"rotation_mean_deg", Optional(e, s.rotation_mean_deg)},
                      {"rotation_max_deg", Optional(e, s.rotation_max_deg)},
                      {"translation_mean_m", Optional(e, s.translation_mean_m)},
                      {"translation_max_m", Optional(e, s.translation_max_m)},
                      {"std_rpy_deg",
                       {Optional(e, s.std_rpy_deg.x()), Optional(e, s.std_rpy_deg.y()),
                        Optional(e, s.std_rpy_deg.z())}},
                      {"std_mean_deg", Optional(e, s.std_rpy_deg.mean())},
                      {"reprojection_mean_px", Optional(e, s.reprojection_mean_px)},
                      {"grid_median_ms", Optional(e, s.grid_median_ms)},
                      {"optimise_median_ms", Optional(e, s.optimise_median_ms)},
                      {"frames_mean", s.frames_mean},
                      {"camera_boards_mean", s.camera_boards_mean},
                      {"per_trajectory", nlohmann::json::array()}};
  for (const auto& r : runs) j["per_trajectory"].push_back(RunJson(r));
  return j;
}

nlohmann::json ByMethodJson(const RunsByMethod& runs) {
  nlohmann::json j;
  for (size_t m = 0; m < runs.size(); ++m) j[MethodName(kMethods[m])] = RunsJson(runs[m]);
  return j;
}

}  // namespace

nlohmann::json CalibJson(const CalibBenchOptions& o, const std::vector<LidarResults>& results) {
  nlohmann::json doc;
  doc["options"] = {{"lidars", o.lidars},
                    {"trajectories", o.trajectories},
                    {"frames", o.frames},
                    {"seed", o.seed},
                    {"trials", o.trials}};
  doc["targets"] = {{"rotation_deg", kRotationTargetDeg},
                    {"translation_m", kTranslationTargetM},
                    {"grid_ms", kGridTargetMs},
                    {"optimise_ms", kOptimiseTargetMs}};
  doc["paper"] = {{"grid_ms", kPaperGridMs},
                  {"optimise_ms", kPaperOptimiseMs},
                  {"grid_trials", kPaperTrials},
                  {"converged_with_search", kPaperConvergedWith},
                  {"converged_without_search", kPaperConvergedWithout}};
  for (const auto& r : results) {
    nlohmann::json& l = doc["lidars"][r.lidar];
    for (const auto& d : r.drives)
      l["trajectories"].push_back({{"seed", d.seed},
                                   {"frames", d.frames},
                                   {"camera_boards", d.camera_boards},
                                   {"lidar_clusters", d.lidar_clusters},
                                   {"incomplete_frames", d.incomplete_frames},
                                   {"detect_s", d.detect_s}});
    l["accuracy"] = RunsJson(r.accuracy);
    for (const auto& a : r.alphas)
      l["table1"].push_back(
          {{"alpha_m", a.alpha_m},
           {"indirect", RunsJson(a.indirect)},
           {"direct", RunsJson(a.direct)},
           {"paper_indirect_px", Optional(true, PaperTableI(PaperColumn(r.lidar), a.alpha_m))}});
    for (const auto& row : r.bands) {
      nlohmann::json band = ByMethodJson(row.runs);
      band["min_m"] = row.min_m;
      band["max_m"] = row.max_m;
      const auto& paper = kPaperTableII[row.name == "close" ? 0 : 1];
      band["paper_std_rpy_deg"] = {
          {"indirect", std::vector<double>(std::begin(paper[0]), std::end(paper[0]))},
          {"direct", std::vector<double>(std::begin(paper[1]), std::end(paper[1]))}};
      l["table2"][row.name] = band;
    }
    for (const auto& s : r.sampling) {
      nlohmann::json row = ByMethodJson(s.runs);
      row["min_step_m"] = s.min_step_m;
      l["fig7"].push_back(row);
    }
    const GridTrials& g = r.grid;
    nlohmann::json grid = {{"trials", g.with_search.size()},
                           {"max_deg", g.max_deg},
                           {"converged_deg", g.converged_deg},
                           {"converged_with_search", g.converged_with},
                           {"converged_without_search", g.converged_without},
                           {"perturbations_deg", nlohmann::json::array()},
                           {"with_search", nlohmann::json::array()},
                           {"without_search", nlohmann::json::array()}};
    for (const auto& p : g.perturbations_deg)
      grid["perturbations_deg"].push_back({p.x(), p.y(), p.z()});
    for (const auto& t : g.with_search) grid["with_search"].push_back(RunJson(t));
    for (const auto& t : g.without_search) grid["without_search"].push_back(RunJson(t));
    l["grid_search"] = grid;
  }
  return doc;
}

}  // namespace calibd::bench
