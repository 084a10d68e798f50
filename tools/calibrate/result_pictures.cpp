#include "result_pictures.hpp"

#include <algorithm>
#include <array>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <utility>

#include "overlay.hpp"

namespace calibd::tools {

std::vector<int> PictureFrames(const ObservationSet& corr) {
  std::map<int, double> dist;
  for (const auto& o : corr.observations) dist[o.frame] = o.T_camera_board.translation().norm();
  std::vector<std::pair<double, int>> by_distance;
  for (const auto& [frame, d] : dist) by_distance.emplace_back(d, frame);
  std::sort(by_distance.begin(), by_distance.end());
  std::vector<int> frames;
  for (int i = 0; i < 4 && !by_distance.empty(); ++i) {
    const size_t k = (by_distance.size() - 1) * static_cast<size_t>(i) / 3;
    if (std::find(frames.begin(), frames.end(), by_distance[k].second) == frames.end())
      frames.push_back(by_distance[k].second);
  }
  return frames;
}

bool DrawResultPictures(const CalibrationRun& run, const CalibConfig& config,
                        const EngineConfig& engine, const PairReader& read_pairs,
                        const std::string& overlay_dir, std::vector<ReportImage>* images,
                        std::string* error) {
  const ObservationSet& corr = run.correspondences;
  const Pose& T_camera_lidar = run.outcome.T_camera_lidar;
  if (corr.observations.empty()) return true;
  if (!overlay_dir.empty()) std::filesystem::create_directories(overlay_dir);
  std::vector<FramePairData> kept;
  if (!read_pairs(PictureFrames(corr), &kept, error)) return false;
  const CameraModel camera(config.camera);
  for (const auto& f : kept) {
    cv::Mat bgr;
    const ImageView view{f.image.data, f.image.cols, f.image.rows,
                         static_cast<int>(f.image.step[0])};
    viz::DrawLidarOverlay(
        view, PointCloudView{f.x.data(), f.y.data(), f.z.data(), nullptr, f.x.size(), nullptr},
        T_camera_lidar, camera, 0.5, &bgr);
    std::vector<Eigen::Vector2d> detected, fitted;
    for (const auto& o : corr.observations) {
      if (o.frame != f.pair_index) continue;
      detected.insert(detected.end(), o.corners_px.begin(), o.corners_px.end());
      std::array<Eigen::Vector2d, 4> px;
      if (!FittedTagCornersPx(camera, config.boards, corr, o, T_camera_lidar, engine.direct, &px))
        continue;
      for (const auto& p : px)
        if (p.allFinite()) fitted.push_back(p);
    }
    viz::DrawMarkers(detected, 0.5, cv::Scalar(0, 255, 0), &bgr);
    viz::DrawMarkers(fitted, 0.5, cv::Scalar(0, 0, 255), &bgr);
    if (images != nullptr) {
      ReportImage image;
      image.caption = "frame pair " + std::to_string(f.pair_index) +
                      ": LiDAR points through the result, detected tag corners in green, "
                      "LiDAR-fitted corners in red";
      cv::imencode(".png", bgr, image.png);
      images->push_back(std::move(image));
    }
    if (overlay_dir.empty()) continue;
    const std::string path = overlay_dir + "/pair_" + std::to_string(f.pair_index) + ".png";
    if (!cv::imwrite(path, bgr)) {
      *error = "cannot write '" + path + "'";
      return false;
    }
  }
  return true;
}

}  // namespace calibd::tools
