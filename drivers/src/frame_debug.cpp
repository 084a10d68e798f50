#include "calibd/drivers/frame_debug.hpp"

#include <algorithm>
#include <cstdio>
#include <nlohmann/json.hpp>
#include <unordered_map>
#include <vector>

#include "calibd/core/lidar/segmentation.hpp"

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/png_writer.hpp"

namespace calibd {

namespace {

nlohmann::json Vec(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// Colours of the picture, defined once with their legend.
struct Swatch {
  const char* what;
  uint8_t b, g, r;
};
constexpr Swatch kBoard{"board (green)", 60, 220, 60};
constexpr Swatch kDescriptor{"descriptor: no reference matched (orange)", 0, 150, 255};
constexpr Swatch kShape{"rectangle or size: not a board's extent (magenta)", 220, 60, 220};
constexpr Swatch kSurface{"not_planar or tilted (blue)", 230, 120, 30};
constexpr Swatch kLarge{"too_large, attached or capacity (red)", 40, 40, 200};
constexpr Swatch kOnGround{"on_ground: stands on the floor (brown)", 40, 90, 140};
constexpr Swatch kGround{"ground (dark green)", 30, 70, 30};
constexpr Swatch kOther{"smaller clusters and other points (grey, brighter nearer)", 0, 0, 0};

const Swatch& SwatchOf(ClusterGate gate) {
  switch (gate) {
    case ClusterGate::kBoard:
      return kBoard;
    case ClusterGate::kDescriptor:
      return kDescriptor;
    case ClusterGate::kRectangle:
    case ClusterGate::kSize:
      return kShape;
    case ClusterGate::kNotPlanar:
    case ClusterGate::kTilted:
      return kSurface;
    case ClusterGate::kOnGround:
      return kOnGround;
    default:
      return kLarge;
  }
}

}  // namespace

void DrawRangeImagePicture(const LidarDetector& detector, const LidarDetections& lidar,
                           RangeImagePicture* out) {
  const RangeImage& image = detector.range_image();
  const std::vector<int32_t>& labels = detector.cell_labels();
  // Segment label -> the whole segment's gate; planes found as boards are drawn over it.
  std::unordered_map<int32_t, ClusterGate> gate_of_label;
  for (const LidarClusterReport& r : lidar.clusters)
    if (r.plane < 0) gate_of_label[detector.segment_label(r.segment)] = r.gate;
  // Rows scaled up for few-ring sensors.
  const int rows = image.rows(), cols = image.cols();
  const int row_px = std::clamp(400 / std::max(1, rows), 1, 24);
  const int col_px = std::clamp(720 / std::max(1, cols), 1, 8);
  out->width = cols * col_px;
  out->height = rows * row_px;
  out->rgb.assign(static_cast<size_t>(out->width) * static_cast<size_t>(out->height) * 3, 0);
  auto paint = [&](int cell, uint8_t r, uint8_t g, uint8_t b) {
    // Top row: the highest elevation; column 0 (azimuth -180 or the field's right edge) drawn on
    // the right, as the sensor sees it.
    const int y0 = (rows - 1 - image.RowOf(cell)) * row_px;
    const int x0 = (cols - 1 - image.ColOf(cell)) * col_px;
    for (int y = y0; y < y0 + row_px; ++y)
      for (int x = x0; x < x0 + col_px; ++x) {
        uint8_t* px = out->rgb.data() + (static_cast<size_t>(y) * out->width + x) * 3;
        px[0] = r;
        px[1] = g;
        px[2] = b;
      }
  };
  auto paint_swatch = [&](int cell, const Swatch& w) { paint(cell, w.r, w.g, w.b); };
  for (int cell = 0; cell < rows * cols; ++cell) {
    const RangeImageCell& c = image.cell(cell);
    if (c.index < 0) continue;
    const int32_t label = static_cast<size_t>(cell) < labels.size() ? labels[cell] : kLabelNone;
    if (label == kLabelGround) {
      paint_swatch(cell, kGround);
      continue;
    }
    const auto it = gate_of_label.find(label);
    if (label > 0 && it != gate_of_label.end()) {
      paint_swatch(cell, SwatchOf(it->second));
      continue;
    }
    const auto grey = static_cast<uint8_t>(std::clamp(220.0 - 6.0 * c.range, 50.0, 220.0));
    paint(cell, grey, grey, grey);
  }
  // Boards found as planes inside a refused cluster: their points' cells.
  const std::vector<int32_t>& point_cell = image.point_cell();
  for (const BoardCluster& b : lidar.boards)
    for (int k = b.first_point; k < b.first_point + b.num_points; ++k) {
      const int32_t i = lidar.point_indices[static_cast<size_t>(k)];
      if (i >= 0 && static_cast<size_t>(i) < point_cell.size() && point_cell[i] >= 0)
        paint_swatch(point_cell[i], kBoard);
    }
}

const char* FrameDebugPictureLegend() {
  static const std::string legend = [] {
    std::string s;
    for (const Swatch* w :
         {&kBoard, &kDescriptor, &kShape, &kSurface, &kLarge, &kOnGround, &kGround, &kOther})
      s += std::string(s.empty() ? "" : "; ") + w->what;
    return s;
  }();
  return legend.c_str();
}

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
                                 {"trimmed_cells", r.trimmed_cells},
                                 {"descriptor_score", r.score}});
  }
  if (in.picture) {
    char picture[32];
    std::snprintf(picture, sizeof(picture), "pair_%06d.png", in.pair_index);
    lidar["picture"] = {{"file", picture}, {"colours", FrameDebugPictureLegend()}};
  }
  j["lidar"] = lidar;
  return j.dump(1) + "\n";
}

bool WriteFrameDebug(const std::string& dir, const FrameDebugInput& in, std::string* error) {
  char name[32];
  std::snprintf(name, sizeof(name), "/pair_%06d.json", in.pair_index);
  if (!WriteFileAtomic(dir + name, FrameDebugJson(in), error)) return false;
  if (!in.picture) return true;
  std::string png, why;
  std::snprintf(name, sizeof(name), "/pair_%06d.png", in.pair_index);
  if (!EncodePngRgb(in.picture->rgb.data(), in.picture->width, in.picture->height, &png, &why)) {
    if (error) *error = dir + name + ": " + why;
    return false;
  }
  return WriteFileAtomic(dir + name, png, error);
}

}  // namespace calibd
