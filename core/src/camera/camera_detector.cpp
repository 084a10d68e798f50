#include "calibd/core/camera/camera_detector.hpp"

#include <apriltag/apriltag.h>
#include <apriltag/common/image_types.h>
#include <apriltag/common/zarray.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "calibd/core/camera/camera_pnp.hpp"
#include "common/apriltag_families.hpp"

namespace calibd {

bool CameraDetectorConfig::IsValid(std::string* error) const {
  std::ostringstream why;
  if (!(quad_decimate >= 1.0f) || !(quad_decimate <= 8.0f) ||
      (quad_decimate != 1.5f && quad_decimate != std::floor(quad_decimate)))
    why << "quad_decimate must be 1.5 or an integer in [1, 8]";
  else if (threads < 1 || threads > 64)
    why << "threads must be in [1, 64]";
  else if (!(quad_sigma >= 0.0 && quad_sigma <= 5.0))
    why << "quad_sigma must be in [0, 5]";
  else if (!(decode_sharpening >= 0.0 && decode_sharpening <= 2.0))
    why << "decode_sharpening must be in [0, 2]";
  else if (!(roi_margin >= 0.0 && roi_margin <= 10.0))
    why << "roi_margin must be in [0, 10]";
  else if (!(roi_min_margin_px >= 0.0 && roi_min_margin_px <= 1000.0))
    why << "roi_min_margin_px must be in [0, 1000]";
  else if (!(roi_min_tag_px >= 10.0))
    why << "roi_min_tag_px must be >= 10";
  else if (roi_max_decimate < 1 || roi_max_decimate > 8)
    why << "roi_max_decimate must be in [1, 8]";
  else if (max_bits_corrected < 0 || max_bits_corrected > 3)
    why << "max_bits_corrected must be in [0, 3]";
  else if (full_frame_every < 0)
    why << "full_frame_every must be >= 0 (0: never while every board is tracked)";
  else if (missing_search_every < 1)
    why << "missing_search_every must be >= 1";
  else if (!(max_stream_gap_s >= 0.0 && max_stream_gap_s <= 3600.0))
    why << "max_stream_gap_s must be in [0, 3600] s";
  else if (!(max_reprojection_rms_px > 0.0))
    why << "max_reprojection_rms_px must be positive";
  else if (!(min_decision_margin >= 0.0))
    why << "min_decision_margin must be >= 0";
  else if (checker_downscale < 1 || checker_downscale > 8)
    why << "checker_downscale must be in [1, 8]";
  if (why.tellp() == 0) return true;
  if (error) *error = why.str();
  return false;
}

namespace {

using Corners = std::array<Eigen::Vector2d, 4>;

// ---- Geometry helpers ----

double MaxSidePx(const Corners& c) {
  double s = 0.0;
  for (size_t k = 0; k < 4; ++k) s = std::max(s, (c[(k + 1) % 4] - c[k]).norm());
  return s;
}

struct DetectorDeleter {
  void operator()(apriltag_detector_t* d) const { apriltag_detector_destroy(d); }
};
struct DetectionsDeleter {
  void operator()(zarray_t* z) const { apriltag_detections_destroy(z); }
};

}  // namespace

struct CameraDetector::Impl {
  // One AprilTag candidate before PnP: full-image corners in OpenCV's pixel convention.
  struct Candidate {
    int board_index = -1;
    Corners corners_px;
    double decision_margin = 0.0;
  };
  struct Track {
    bool active = false;
    Corners corners_px;
  };

  CameraDetectorConfig config;
  CameraModel model;
  std::vector<BoardGeometry> boards;
  bool ok = false;
  std::string error;

  // AprilTag objects, created once and reused (STYLE.md: it allocates per call, so at least the
  // detector, its worker pool and the family's quick-decode table are not rebuilt per frame). The
  // family must outlive the detector: the detector is destroyed first.
  const internal::AprilTagFamilyEntry* family_entry = nullptr;
  apriltag_family_t* family = nullptr;
  std::unique_ptr<apriltag_detector_t, DetectorDeleter> td;
  std::vector<int> tag_boards;  // indices into boards of the AprilTag boards
  int checker_board = -1;       // index of the (single) checkerboard board, or -1

  TagSearchMemo* memo = nullptr;  // UseSearchMemo's
  std::string memo_settings;      // what besides the window makes AprilTag's results differ

  // Tracking state (per board index).
  std::vector<Track> tracks;
  int frames_since_full = std::numeric_limits<int>::max() / 2;
  int64_t last_utime = kUnknownCaptureTime;  // capture time of the previous frame

  // The next frame searches the whole image.
  void ForgetTracks() {
    for (auto& t : tracks) t.active = false;
    frames_since_full = std::numeric_limits<int>::max() / 2;
  }

  // Scratch reused across frames, sized in the constructor.
  std::vector<Candidate> candidates;
  std::vector<uint8_t> blur_copy;  // crop copy when AprilTag would blur the caller's pixels
  cv::Mat checker_small;
  std::vector<cv::Point2f> checker_corners;
  std::vector<Eigen::Vector3d> checker_board_points;
  std::vector<Eigen::Vector2d> checker_px;

  Impl(const CameraDetectorConfig& c, const CameraIntrinsics& intrinsics,
       const std::vector<BoardGeometry>& b)
      : config(c), model(intrinsics), boards(b) {}

  ~Impl() {
    td.reset();
    if (family) family_entry->destroy(family);
  }

  bool Init(const CameraIntrinsics& intrinsics) {
    std::string why;
    if (!config.IsValid(&why)) return Fail("config: " + why);
    if (!intrinsics.IsValid(&why)) return Fail("intrinsics: " + why);
    if (boards.empty()) return Fail("boards: no boards configured");
    for (size_t i = 0; i < boards.size(); ++i) {
      const BoardGeometry& g = boards[i];
      if (!g.IsValid(&why)) return Fail("boards: " + why);
      for (size_t j = 0; j < i; ++j) {
        if (boards[j].board_id == g.board_id)
          return Fail("boards: board_id " + std::to_string(g.board_id) + " appears twice");
      }
      if (g.pattern == BoardGeometry::PatternKind::kCheckerboard) {
        if (checker_board >= 0)
          return Fail("boards: only one checkerboard board is supported per camera");
        checker_board = static_cast<int>(i);
        continue;
      }
      const internal::AprilTagFamilyEntry* f = internal::FindAprilTagFamily(g.tag_family);
      if (!f) {
        return Fail("boards: board " + std::to_string(g.board_id) + ": unknown tag_family '" +
                    g.tag_family + "'");
      }
      if (family_entry && f != family_entry) {
        return Fail("boards: board " + std::to_string(g.board_id) + ": tag_family '" +
                    g.tag_family + "' differs from '" + family_entry->name +
                    "' (one tag family per camera detector)");
      }
      for (int j : tag_boards) {
        if (boards[static_cast<size_t>(j)].tag_id == g.tag_id)
          return Fail("boards: tag_id " + std::to_string(g.tag_id) + " appears twice");
      }
      family_entry = f;
      tag_boards.push_back(static_cast<int>(i));
    }
    if (family_entry) {
      family = family_entry->create();
      for (int j : tag_boards) {
        if (boards[static_cast<size_t>(j)].tag_id >= static_cast<int>(family->ncodes)) {
          return Fail("boards: board " + std::to_string(boards[static_cast<size_t>(j)].board_id) +
                      ": tag_id out of range for " + family_entry->name);
        }
      }
      td.reset(apriltag_detector_create());
      apriltag_detector_add_family_bits(td.get(), family, config.max_bits_corrected);
      td->nthreads = config.threads;
      td->quad_decimate = config.quad_decimate;
      td->quad_sigma = static_cast<float>(config.quad_sigma);
      td->refine_edges = config.refine_edges;
      td->decode_sharpening = config.decode_sharpening;
      memo_settings =
          std::string(family_entry->name) + "/" + std::to_string(config.max_bits_corrected) + "/" +
          std::to_string(config.threads) + "/" + std::to_string(config.quad_sigma) + "/" +
          std::to_string(config.refine_edges) + "/" + std::to_string(config.decode_sharpening);
    }
    tracks.assign(boards.size(), Track{});
    candidates.reserve(4 * boards.size() + 16);
    if (checker_board >= 0) {
      const BoardGeometry& g = boards[static_cast<size_t>(checker_board)];
      checker_board_points = g.CheckerCornersInBoard();
      checker_corners.reserve(checker_board_points.size());
      checker_px.reserve(checker_board_points.size());
    }
    ok = true;
    return true;
  }

  bool Fail(const std::string& why) {
    error = why;
    ok = false;
    return false;
  }

  // ---- AprilTag search ----

  int BoardIndexForTag(int tag_id) const {
    for (int j : tag_boards) {
      if (boards[static_cast<size_t>(j)].tag_id == tag_id) return j;
    }
    return -1;
  }

  // Runs AprilTag on a window of the image (no copy: the crop is wrapped with the image's stride)
  // and appends candidates with full-image corners. AprilTag allocates its results, its decimated
  // image and its quad lists on every call (libapriltag 3.3 has no workspace API).
  void SearchWindow(const ImageView& im, int x0, int y0, int w, int h, float decimate,
                    CameraDetections* out) {
    if (w < 16 || h < 16) return;
    auto take = [&](int id, float decision_margin, const double(*p)[2]) {
      const int board = BoardIndexForTag(id);
      if (board < 0 || decision_margin < config.min_decision_margin) {
        ++out->rejected;
        return;
      }
      Candidate c;
      c.board_index = board;
      c.decision_margin = decision_margin;
      // libapriltag reports pixel centres at i + 0.5 (docs/conventions.md#apriltag-pixels).
      for (size_t k = 0; k < 4; ++k) c.corners_px[k] = {p[k][0] - 0.5 + x0, p[k][1] - 0.5 + y0};
      AddCandidate(c, out);
    };
    TagSearchMemo::Search* kept = nullptr;
    if (memo != nullptr) {
      for (TagSearchMemo::Search& s : memo->searches_) {
        if (s.data != im.data || s.stride != im.stride || s.x0 != x0 || s.y0 != y0 ||
            s.width != w || s.height != h || s.decimate != decimate || s.settings != memo_settings)
          continue;
        for (const TagSearchMemo::Tag& t : s.tags) {
          const double p[4][2] = {{t.corners[0].x(), t.corners[0].y()},
                                  {t.corners[1].x(), t.corners[1].y()},
                                  {t.corners[2].x(), t.corners[2].y()},
                                  {t.corners[3].x(), t.corners[3].y()}};
          take(t.id, t.decision_margin, p);
        }
        ++memo->reused_;
        return;
      }
      kept = &memo->searches_.emplace_back();
      *kept = {im.data, im.stride, x0, y0, w, h, decimate, memo_settings, {}};
    }
    uint8_t* buf = const_cast<uint8_t*>(im.data) + static_cast<size_t>(y0) * im.stride + x0;
    int stride = im.stride;
    // libapriltag blurs (quad_sigma) the quad-search image in place, and at decimation 1 that is
    // the caller's image: work on a copy then.
    if (config.quad_sigma > 0.0 && decimate <= 1.0f) {
      blur_copy.resize(static_cast<size_t>(w) * static_cast<size_t>(h));
      for (int r = 0; r < h; ++r)
        std::memcpy(blur_copy.data() + static_cast<size_t>(r) * w,
                    buf + static_cast<size_t>(r) * im.stride, static_cast<size_t>(w));
      buf = blur_copy.data();
      stride = w;
    }
    image_u8_t view{w, h, stride, buf};
    td->quad_decimate = decimate;
    std::unique_ptr<zarray_t, DetectionsDeleter> dets(apriltag_detector_detect(td.get(), &view));
    for (int i = 0; i < zarray_size(dets.get()); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(dets.get(), i, &d);
      if (kept != nullptr) {
        TagSearchMemo::Tag& t = kept->tags.emplace_back();
        t.id = d->id;
        t.decision_margin = d->decision_margin;
        for (size_t k = 0; k < 4; ++k) t.corners[k] = {d->p[k][0], d->p[k][1]};
      }
      take(d->id, d->decision_margin, d->p);
    }
  }

  // Keeps one candidate per board: overlapping crops find the same tag twice (same place, not a
  // rejection); a second decode of a configured id elsewhere is a false decode
  // (docs/conventions.md#small-families): the higher decision margin wins.
  void AddCandidate(const Candidate& c, CameraDetections* out) {
    for (auto& other : candidates) {
      if (other.board_index != c.board_index) continue;
      const double moved = (other.corners_px[0] - c.corners_px[0]).norm();
      if (moved > 2.0) ++out->rejected;
      if (c.decision_margin > other.decision_margin) other = c;
      return;
    }
    candidates.push_back(c);
  }

  void SearchFullFrame(const ImageView& im, CameraDetections* out) {
    candidates.clear();
    SearchWindow(im, 0, 0, im.width, im.height, config.quad_decimate, out);
    out->full_frame_search = true;
  }

  // Searches crops around the tracked boards; false when a tracked board was not found (lost).
  bool SearchTracked(const ImageView& im, CameraDetections* out) {
    candidates.clear();
    for (size_t b = 0; b < tracks.size(); ++b) {
      if (!tracks[b].active) continue;
      const Corners& c = tracks[b].corners_px;
      const double tag_px = MaxSidePx(c);
      double xmin = c[0].x(), xmax = c[0].x(), ymin = c[0].y(), ymax = c[0].y();
      for (const auto& p : c) {
        xmin = std::min(xmin, p.x());
        xmax = std::max(xmax, p.x());
        ymin = std::min(ymin, p.y());
        ymax = std::max(ymax, p.y());
      }
      const double grow = config.roi_margin * tag_px + config.roi_min_margin_px;
      const int x0 = std::max(0, static_cast<int>(std::floor(xmin - grow)));
      const int y0 = std::max(0, static_cast<int>(std::floor(ymin - grow)));
      const int x1 = std::min(im.width, static_cast<int>(std::ceil(xmax + grow)) + 1);
      const int y1 = std::min(im.height, static_cast<int>(std::ceil(ymax + grow)) + 1);
      if (x1 <= x0 || y1 <= y0) continue;
      const int decimate =
          std::clamp(static_cast<int>(tag_px / config.roi_min_tag_px), 1, config.roi_max_decimate);
      SearchWindow(im, x0, y0, x1 - x0, y1 - y0, static_cast<float>(decimate), out);
    }
    for (size_t b = 0; b < tracks.size(); ++b) {
      if (!tracks[b].active) continue;
      const bool found = std::any_of(candidates.begin(), candidates.end(), [&](const Candidate& c) {
        return c.board_index == static_cast<int>(b);
      });
      if (!found) return false;
    }
    return true;
  }

  bool FinishDetection(const BoardGeometry& g, BoardDetection2D* det) const {
    const Eigen::Vector3d centre_c = det->T_camera_board.translation();
    if (!(centre_c.z() > 1e-9)) return false;
    det->board_id = g.board_id;
    det->centre_px = model.DistortToPixel(centre_c.head<2>() / centre_c.z());
    return det->reprojection_rms_px <= config.max_reprojection_rms_px;
  }

  void ResolveCandidates(CameraDetections* out) {
    for (auto& c : candidates) {
      const BoardGeometry& g = boards[static_cast<size_t>(c.board_index)];
      // Corners: AprilTag's refined quad (refine_edges) as is. Corner error vs truth on simulated
      // 3840x1920 frames (test_camera_detector, median/max px at 6, 10, 15, 30 m):
      //   AprilTag alone:     0.114/0.222, 0.054/0.197, 0.065/0.175, 0.070/0.163
      //   + cv::cornerSubPix: 0.149/0.217, 0.141/0.257, 0.132/0.305, 0.227/0.327
      //   + edge-line fit:    0.094/0.636, 0.110/0.465, 0.130/0.336, 0.335/0.532
      // cornerSubPix is biased inward at an L-corner under blur (depth error 18 cm at 30 m vs 8
      // cm); a line fit to the four edges in undistorted coordinates was worse too. Neither is
      // applied.
      BoardDetection2D det;
      det.corners_px = c.corners_px;
      det.decision_margin = c.decision_margin;
      if (!EstimateTagPose(model, g, c.corners_px, &det.T_camera_board, &det.reprojection_rms_px)) {
        ++out->rejected;
        continue;
      }
      if (!FinishDetection(g, &det)) {
        ++out->rejected;
        continue;
      }
      out->boards.push_back(det);
    }
  }

  // ---- Checkerboard ----

  // `still`: a frame outside a stream, whose time allows a full-resolution search when the
  // downscaled one finds nothing (a small board: squares under about 8 px).
  void DetectCheckerboard(const ImageView& im, bool still, CameraDetections* out) {
    const BoardGeometry& g = boards[static_cast<size_t>(checker_board)];
    const cv::Mat full(im.height, im.width, CV_8UC1, const_cast<uint8_t*>(im.data),
                       static_cast<size_t>(im.stride));
    int f = config.checker_downscale;
    const cv::Size pattern(g.checker_inner_cols, g.checker_inner_rows);
    bool found = false;
    if (f > 1) {
      cv::resize(full, checker_small, cv::Size(im.width / f, im.height / f), 0, 0, cv::INTER_AREA);
      found = cv::findChessboardCornersSB(checker_small, pattern, checker_corners,
                                          cv::CALIB_CB_NORMALIZE_IMAGE);
    }
    if (!found && (f == 1 || still)) {
      f = 1;
      found =
          cv::findChessboardCornersSB(full, pattern, checker_corners, cv::CALIB_CB_NORMALIZE_IMAGE);
    }
    const size_t n = checker_board_points.size();
    if (!found || checker_corners.size() != n) return;
    // Back to full-resolution pixels (INTER_AREA: small pixel i covers full pixels f i .. f i+f-1,
    // centre f i + (f - 1) / 2), then refine there.
    for (auto& p : checker_corners) {
      p.x = static_cast<float>(p.x * static_cast<double>(f) + (f - 1) / 2.0);
      p.y = static_cast<float>(p.y * static_cast<double>(f) + (f - 1) / 2.0);
    }
    const double square_px = std::hypot(checker_corners[1].x - checker_corners[0].x,
                                        checker_corners[1].y - checker_corners[0].y);
    const int win = std::clamp(static_cast<int>(square_px / 3.0), 2, 12);
    cv::cornerSubPix(full, checker_corners, cv::Size(win, win), cv::Size(-1, -1),
                     cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 40, 0.001));
    // findChessboardCornersSB may start the grid at either end (a 180 deg turn of the board looks
    // the same): make row 0 the top row and columns run left to right, as for an upright board.
    const int rows = g.checker_inner_rows, cols = g.checker_inner_cols;
    const cv::Point2f row_dir = checker_corners[static_cast<size_t>(cols - 1)] - checker_corners[0];
    const cv::Point2f col_dir =
        checker_corners[static_cast<size_t>((rows - 1) * cols)] - checker_corners[0];
    if (row_dir.x < 0.0f && col_dir.y < 0.0f)
      std::reverse(checker_corners.begin(), checker_corners.end());
    else if (row_dir.x < 0.0f || col_dir.y < 0.0f) {
      // Mirrored (or transposed for a square grid): not an upright board seen from the front.
      ++out->rejected;
      return;
    }

    checker_px.clear();
    for (const auto& p : checker_corners) checker_px.emplace_back(p.x, p.y);
    BoardDetection2D det;
    if (!EstimatePlanarPose(model, checker_board_points, checker_px, &det.T_camera_board,
                            &det.reprojection_rms_px)) {
      ++out->rejected;
      return;
    }
    // The 4 outermost inner corners in AprilTag's order: bottom-left, bottom-right, top-right,
    // top-left (BoardGeometry::TagCornersInBoard for a checkerboard).
    const size_t bl = static_cast<size_t>((rows - 1) * cols), br = n - 1,
                 tr = static_cast<size_t>(cols - 1), tl = 0;
    const size_t order[4] = {bl, br, tr, tl};
    for (size_t k = 0; k < 4; ++k)
      det.corners_px[k] = {checker_corners[order[k]].x, checker_corners[order[k]].y};
    if (!FinishDetection(g, &det)) {
      ++out->rejected;
      return;
    }
    out->boards.push_back(det);
  }

  // ---- One frame ----

  void Detect(const ImageView& im, CameraDetections* out, int64_t capture_utime) {
    // Reserved on the first use of `out` (at most one detection per configured board); later
    // frames only clear and refill.
    if (out->boards.capacity() < boards.size()) out->boards.reserve(boards.size());
    out->boards.clear();
    out->full_frame_search = false;
    out->rejected = 0;
    if (!ok || !im.data || im.width < 16 || im.height < 16 || im.stride < im.width) return;
    const bool stream =
        capture_utime != kUnknownCaptureTime && last_utime != kUnknownCaptureTime &&
        capture_utime > last_utime &&
        static_cast<double>(capture_utime - last_utime) <= config.max_stream_gap_s * 1e6;
    last_utime = capture_utime;
    if (!stream) ForgetTracks();
    if (td) {
      int tracked = 0;
      for (const auto& t : tracks) tracked += t.active ? 1 : 0;
      const int configured = static_cast<int>(tag_boards.size());
      // The search policy of CameraDetectorConfig::track_rois.
      const int since = frames_since_full + 1;
      bool full = !config.track_rois || tracked == 0 ||
                  (tracked < configured && since >= config.missing_search_every) ||
                  (config.full_frame_every > 0 && since >= config.full_frame_every);
      if (tracked == 0 && since < config.missing_search_every) {
        // Nothing tracked and searched recently: skip this frame rather than pay a full search.
        ++frames_since_full;
        for (auto& t : tracks) t.active = false;
        if (checker_board >= 0) DetectCheckerboard(im, !stream, out);
        return;
      }
      if (!full && !SearchTracked(im, out)) full = true;  // a tracked board was lost
      if (full) {
        SearchFullFrame(im, out);
        frames_since_full = 0;
      } else {
        ++frames_since_full;
      }
      ResolveCandidates(out);
      for (auto& t : tracks) t.active = false;
      for (const auto& det : out->boards) {
        for (size_t b = 0; b < boards.size(); ++b) {
          if (boards[b].board_id != det.board_id) continue;
          tracks[b].active = true;
          tracks[b].corners_px = det.corners_px;
        }
      }
    }
    if (checker_board >= 0) DetectCheckerboard(im, !stream, out);
  }
};

CameraDetector::CameraDetector(const CameraDetectorConfig& config,
                               const CameraIntrinsics& intrinsics,
                               const std::vector<BoardGeometry>& boards)
    : impl_(std::make_unique<Impl>(config, intrinsics, boards)) {
  impl_->Init(intrinsics);
}

CameraDetector::~CameraDetector() = default;

bool CameraDetector::ok() const { return impl_->ok; }

const std::string& CameraDetector::error() const { return impl_->error; }

void CameraDetector::Detect(const ImageView& image, CameraDetections* out, int64_t capture_utime) {
  impl_->Detect(image, out, capture_utime);
  for (BoardDetection2D& det : out->boards)
    for (const BoardGeometry& g : impl_->boards)
      if (g.board_id == det.board_id)
        det.outline = MeasureBoardOutline(image, impl_->model, g, det.T_camera_board);
}

void CameraDetector::ReserveOutput(CameraDetections* out) const {
  if (out->boards.capacity() < impl_->boards.size()) out->boards.reserve(impl_->boards.size());
}

void CameraDetector::ResetTracking() { impl_->ForgetTracks(); }

void CameraDetector::UseSearchMemo(TagSearchMemo* memo) { impl_->memo = memo; }

}  // namespace calibd
