#include "detect_bench.hpp"

#include <cmath>
#include <iomanip>
#include <nlohmann/json.hpp>
#include <ostream>

#include "calibd/core/camera/camera_detector.hpp"
#include "calibd/core/common/stats.hpp"
#include "calibd/core/lidar/lidar_detector.hpp"
#include "calibd/drivers/atomic_file.hpp"
#include "session_detector.hpp"

namespace calibd::bench {

namespace {

/// What one LiDAR frame contributes to precision/recall at any threshold.
struct LidarFrameEval {
  std::vector<Eigen::Vector3d> truth_centres;  ///< visible boards, LiDAR frame
  std::vector<LidarCandidate> candidates;      ///< every gated cluster with its score
  std::vector<Eigen::Vector3d> detections;     ///< the detector's own output (configured threshold)
};

struct Counts {
  int tp = 0, fp = 0, fn = 0;
  double precision() const { return tp + fp > 0 ? static_cast<double>(tp) / (tp + fp) : 1.0; }
  double recall() const { return tp + fn > 0 ? static_cast<double>(tp) / (tp + fn) : 1.0; }
};

// Greedy one-to-one matching of detections to true centres within `radius` (paper §IV-B: a
// detection close to a labelled centre is a TP, others FP; unmatched centres are FN).
void Score(const std::vector<Eigen::Vector3d>& detections,
           const std::vector<Eigen::Vector3d>& truth, double radius, Counts* c) {
  std::vector<bool> used(truth.size(), false);
  for (const auto& d : detections) {
    int best = -1;
    double best_dist = radius;
    for (size_t t = 0; t < truth.size(); ++t) {
      const double dist = (d - truth[t]).norm();
      if (!used[t] && dist <= best_dist) {
        best = static_cast<int>(t);
        best_dist = dist;
      }
    }
    if (best >= 0) {
      used[best] = true;
      ++c->tp;
    } else {
      ++c->fp;
    }
  }
  for (bool u : used) c->fn += u ? 0 : 1;
}

Counts ScoreAtThreshold(const std::vector<LidarFrameEval>& frames, double threshold,
                        double radius) {
  Counts c;
  std::vector<Eigen::Vector3d> dets;
  for (const auto& f : frames) {
    dets.clear();
    for (const auto& cand : f.candidates)
      if (cand.score >= threshold) dets.push_back(cand.centroid);
    Score(dets, f.truth_centres, radius, &c);
  }
  return c;
}

struct TimeSeries {
  std::vector<double> total, range_image, ground, segmentation, descriptor;
};

struct CameraEval {
  Counts counts;
  std::vector<double> corner_err_near, corner_err_far;  ///< px; near: board < 15 m from the camera
  std::vector<double> time_ms;
  int full_frame_searches = 0;
};

void PrintTimeRow(std::ostream& out, const std::string& name, const std::vector<double>& v) {
  out << "  " << std::left << std::setw(26) << name << std::right << std::fixed
      << std::setprecision(2) << std::setw(9) << Median(v) << std::setw(9) << Quantile(v, 0.95)
      << "\n";
}

nlohmann::json TimeJson(const std::vector<double>& v) {
  return {{"median_ms", Median(v)}, {"p95_ms", Quantile(v, 0.95)}};
}

}  // namespace

bool RunDetectBench(const DetectBenchOptions& o, std::ostream& out, std::ostream* progress,
                    std::string* error) {
  nlohmann::json doc;
  doc["frames"] = o.frames;
  doc["seed"] = o.seed;
  doc["match_radius_m"] = o.match_radius_m;
  CameraEval cam;
  bool camera_done = false;

  for (const std::string& lidar : o.lidars) {
    DetectedSession detected;
    if (!detected.Init(BenchSessionOptions(lidar, o.seed, o.frames), error)) return false;
    const sim::SessionSimulator& session = detected.session();
    const auto& geometries = session.workshop().geometries;
    const LidarDetectorConfig& lcfg = detected.lidar_config();

    FrameDetections frame;
    const sim::FrameTruth& truth = frame.truth;
    const LidarDetections& lidar_out = frame.lidar;
    const CameraDetections& camera_out = frame.camera;
    std::vector<LidarFrameEval> evals;
    TimeSeries times;
    const Pose T_vehicle_lidar = session.T_vehicle_lidar();

    for (int k = 0; k < session.num_frames(); ++k) {
      // The camera sees the same images whichever LiDAR is fitted: evaluate it once.
      detected.Detect(k, !camera_done, &frame);
      times.total.push_back(frame.lidar_ms);
      times.range_image.push_back(lidar_out.times.range_image_ms);
      times.ground.push_back(lidar_out.times.ground_ms);
      times.segmentation.push_back(lidar_out.times.segmentation_ms);
      times.descriptor.push_back(lidar_out.times.descriptor_ms);

      // True centres in the LiDAR frame at the camera time (the sweep crosses the boards then:
      // phase lock), for boards the LiDAR actually hit.
      LidarFrameEval ev;
      const Pose T_lidar_world = (truth.T_world_vehicle * T_vehicle_lidar).inverse();
      for (size_t b = 0; b < truth.boards.size(); ++b) {
        if (static_cast<int>(truth.boards[b].lidar_point_indices.size()) < o.min_truth_points)
          continue;
        ev.truth_centres.push_back(T_lidar_world *
                                   session.workshop().scene.boards[b].T_world_board.translation());
      }
      ev.candidates = lidar_out.candidates;
      for (const auto& bc : lidar_out.boards) ev.detections.push_back(bc.centroid);
      evals.push_back(std::move(ev));

      if (!camera_done) {
        cam.time_ms.push_back(frame.camera_ms);
        cam.full_frame_searches += camera_out.full_frame_search ? 1 : 0;
        std::vector<bool> seen(truth.boards.size(), false);
        for (const auto& d : camera_out.boards) {
          int b = -1;
          for (size_t i = 0; i < geometries.size(); ++i)
            if (geometries[i].board_id == d.board_id) b = static_cast<int>(i);
          if (b < 0 || !truth.boards[b].tag_in_image || seen[b]) {
            ++cam.counts.fp;
            continue;
          }
          seen[b] = true;
          const auto& T = truth.boards[b].T_camera_board;
          const auto corners = geometries[b].TagCornersInBoard();
          double worst = 0.0;
          std::vector<double> errs;
          for (int c = 0; c < 4; ++c) {
            Eigen::Vector2d uv;
            session.camera_model().Project(T * corners[c], &uv, 1e6);
            errs.push_back((uv - d.corners_px[c]).norm());
            worst = std::max(worst, errs.back());
          }
          if (worst > 3.0) {  // the right id in the wrong place is a false detection
            ++cam.counts.fp;
            seen[b] = false;
            continue;
          }
          ++cam.counts.tp;
          auto& bin = T.translation().norm() < 15.0 ? cam.corner_err_near : cam.corner_err_far;
          bin.insert(bin.end(), errs.begin(), errs.end());
        }
        for (size_t b = 0; b < truth.boards.size(); ++b)
          if (truth.boards[b].tag_in_image && !seen[b]) ++cam.counts.fn;
      }
      if (progress && (k + 1) % 20 == 0)
        *progress << "calibd-bench detect: " << lidar << " frame " << (k + 1) << "/"
                  << session.num_frames() << "\n"
                  << std::flush;
    }

    // LiDAR table for this model.
    Counts at_config;
    for (const auto& f : evals) Score(f.detections, f.truth_centres, o.match_radius_m, &at_config);
    out << "\nLiDAR " << lidar << ": " << evals.size() << " frames, " << at_config.tp + at_config.fn
        << " visible boards (>= " << o.min_truth_points << " points), threshold "
        << lcfg.match_threshold << "\n";
    out << std::fixed << std::setprecision(4) << "  precision " << at_config.precision()
        << "   recall " << at_config.recall() << "   (TP " << at_config.tp << ", FP "
        << at_config.fp << ", FN " << at_config.fn << ")\n";
    out << "  threshold  precision  recall\n";
    nlohmann::json curve = nlohmann::json::array();
    for (int i = 70; i <= 99; i += (i < 90 ? 5 : 1)) {
      const double th = i / 100.0;
      const Counts c = ScoreAtThreshold(evals, th, o.match_radius_m);
      out << "  " << std::setprecision(2) << std::setw(9) << th << std::setprecision(4)
          << std::setw(11) << c.precision() << std::setw(8) << c.recall() << "\n";
      curve.push_back({{"threshold", th}, {"precision", c.precision()}, {"recall", c.recall()}});
    }
    out << "  stage                      median_ms   p95_ms\n";
    PrintTimeRow(out, "range image", times.range_image);
    PrintTimeRow(out, "ground", times.ground);
    PrintTimeRow(out, "segmentation", times.segmentation);
    PrintTimeRow(out, "gates + M2DP + match", times.descriptor);
    PrintTimeRow(out, "LiDAR detection total", times.total);
    doc["lidar"][lidar] = {{"precision", at_config.precision()},
                           {"recall", at_config.recall()},
                           {"tp", at_config.tp},
                           {"fp", at_config.fp},
                           {"fn", at_config.fn},
                           {"threshold", lcfg.match_threshold},
                           {"pr_curve", curve},
                           {"time",
                            {{"range_image", TimeJson(times.range_image)},
                             {"ground", TimeJson(times.ground)},
                             {"segmentation", TimeJson(times.segmentation)},
                             {"descriptor", TimeJson(times.descriptor)},
                             {"total", TimeJson(times.total)}}}};

    if (!camera_done) {
      camera_done = true;
      out << "\nCamera (3840x1920, AprilTag " << geometries.front().tag_family
          << "): " << cam.time_ms.size() << " frames, " << cam.counts.tp + cam.counts.fn
          << " boards in view\n";
      out << std::setprecision(4) << "  precision " << cam.counts.precision() << "   recall "
          << cam.counts.recall() << "   (TP " << cam.counts.tp << ", FP " << cam.counts.fp
          << ", FN " << cam.counts.fn << ")\n";
      out << std::setprecision(3) << "  corner error < 15 m: median " << Median(cam.corner_err_near)
          << " px, p95 " << Quantile(cam.corner_err_near, 0.95) << " px ("
          << cam.corner_err_near.size() << " corners)\n"
          << "  corner error >= 15 m: median " << Median(cam.corner_err_far) << " px, p95 "
          << Quantile(cam.corner_err_far, 0.95) << " px (" << cam.corner_err_far.size()
          << " corners)\n";
      out << "  stage                      median_ms   p95_ms\n";
      PrintTimeRow(out, "camera detection", cam.time_ms);
      out << "  full-frame searches: " << cam.full_frame_searches << " of " << cam.time_ms.size()
          << " frames\n";
      doc["camera"] = {{"precision", cam.counts.precision()},
                       {"recall", cam.counts.recall()},
                       {"tp", cam.counts.tp},
                       {"fp", cam.counts.fp},
                       {"fn", cam.counts.fn},
                       {"corner_error_near_median_px", Median(cam.corner_err_near)},
                       {"corner_error_near_p95_px", Quantile(cam.corner_err_near, 0.95)},
                       {"corner_error_far_median_px", Median(cam.corner_err_far)},
                       {"corner_error_far_p95_px", Quantile(cam.corner_err_far, 0.95)},
                       {"time", TimeJson(cam.time_ms)},
                       {"full_frame_searches", cam.full_frame_searches}};
    }
  }
  if (!o.json_path.empty() && !WriteFileAtomic(o.json_path, doc.dump(2) + "\n", error))
    return false;
  return true;
}

}  // namespace calibd::bench
