#pragma once
/// \file
/// The calibration as one self-contained HTML page for people: the verdict with
/// its reason, T_camera_lidar and its inverse, the change against the prior, the quality figures
/// beside the gates they were judged by, the reprojection errors per board and against distance
/// as inline SVG plots, the overlay pictures, and provenance (software version, config hash,
/// frames used, input, date).
///
/// The page loads nothing: no script, font, style sheet or image from anywhere (pictures are
/// `data:` URIs of PNG bytes, plots are SVG drawn here, the style is inline), and its
/// Content-Security-Policy forbids the browser to fetch anything else. Every string that comes
/// from outside (frame names, paths, reasons, captions) is HTML-escaped.
///
/// RenderHtmlReport() is pure text from a value; WriteHtmlReport() writes it atomically.

#include <cstdint>
#include <string>
#include <string_view>
#include <vector>

#include "calibd/core/engine/calibration_engine.hpp"

namespace calibd::tools {

/// One picture for the report: PNG bytes (e.g. from cv::imencode) and a caption.
struct ReportImage {
  std::string caption;
  std::vector<unsigned char> png;
};

/// Paper Table I error of one board correspondence (its LiDAR-fitted tag corners against the
/// camera's), for the per-board and per-distance plots.
struct BoardReprojection {
  int board_index = -1;     ///< index into HtmlReportInput::board_names
  double distance_m = 0.0;  ///< camera to board centre
  double mean_px = 0.0;     ///< mean over the tag's corners; NaN when the board's fit failed
};

/// Where the result came from.
struct ReportProvenance {
  std::string software_version;  ///< e.g. "calibd 0.1.0"
  std::string input_path;        ///< the recorded session (log or folder)
  std::string config_path;
  std::string config_sha256;  ///< hex SHA-256 of the config file's bytes (Sha256Hex)
  std::string method;         ///< "direct" or "indirect"
  int64_t generated_unix_s = 0;
  int camera_frames = 0, lidar_frames = 0, pairs = 0;  ///< read from the input
  int unpaired_camera = 0, unpaired_lidar = 0, bad_messages = 0;
  int camera_boards = 0, lidar_boards = 0;  ///< detections over all pairs
};

/// Everything the page shows. A value type.
struct HtmlReportInput {
  CalibrationOutcome outcome;
  VerdictConfig gates;      ///< the quality gates the verdict applied (EngineConfig::verdict)
  CameraIntrinsics camera;  ///< the intrinsics the gates judged with (CalibConfig::camera)
  std::string camera_frame = "camera", lidar_frame = "lidar";
  std::vector<std::string> board_names;  ///< per configured board, e.g. "board 3 (tag36h11 #3)"
  std::vector<BoardReprojection> reprojection;
  std::vector<ReportImage> images;
  ReportProvenance provenance;
  /// Error against a ground truth (simulated sessions only); negative: none.
  double truth_rotation_deg = -1.0, truth_translation_m = -1.0;
};

/// The plots' points: each correspondence of `set` (Calibrate's `correspondences`) with its
/// error from Calibrate's `reprojection_px` (index for index; none when that is empty, i.e. the
/// calibration stopped before the solve).
std::vector<BoardReprojection> ReprojectionPerCorrespondence(const ObservationSet& set,
                                                             const std::vector<double>& mean_px);

/// Plot labels of the configured boards: "board <id> (<family> #<tag>)" or "board <id>
/// (checkerboard)".
std::vector<std::string> BoardNames(const std::vector<BoardGeometry>& boards);

/// The page's text.
std::string RenderHtmlReport(const HtmlReportInput& input);

/// Renders and writes `path` atomically (WriteFileAtomic). False with `error` naming the path.
bool WriteHtmlReport(const std::string& path, const HtmlReportInput& input, std::string* error);

/// `text` with & < > " ' replaced by their character references.
std::string HtmlEscape(std::string_view text);

/// Standard base64 (RFC 4648 §4, with padding).
std::string Base64(const unsigned char* data, size_t size);

/// Lower-case hex SHA-256 of `bytes` (OpenSSL); empty if OpenSSL fails.
std::string Sha256Hex(std::string_view bytes);

}  // namespace calibd::tools
