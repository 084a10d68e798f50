#pragma once
/// \file
/// Camera marker detection (paper §III-B): AprilTag (or checkerboard) boards in a mono8 image,
/// their 4 tag corners with sub-pixel refinement, the board centre, and T_camera_board from PnP.
/// The detector is created once and reused; it keeps the last detections to predict regions of
/// interest in the next frame.

#include <array>
#include <cstdint>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "calibd/core/camera/board_outline.hpp"
#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"
#include "calibd/core/common/image_view.hpp"

namespace calibd {

/// The capture time of a frame whose time the caller does not know (CameraDetector::Detect).
inline constexpr int64_t kUnknownCaptureTime = std::numeric_limits<int64_t>::min();

struct CameraDetectorConfig {
  /// AprilTag quad_decimate for full-frame searches: 2 halves the resolution of the quad search
  /// (about 4x faster); corners are still refined at full resolution (refine_edges). AprilTag
  /// supports 1.5 and integer factors only.
  float quad_decimate = 2.0f;
  int threads = 2;           ///< AprilTag worker threads
  bool refine_edges = true;  ///< AprilTag's edge refinement at full resolution
  double quad_sigma = 0.0;   ///< Gaussian blur before the quad search (noisy images: 0.8)
  /// AprilTag decode_sharpening: sharpens the sampled bits; helps small (far) tags decode.
  double decode_sharpening = 0.25;
  /// Bit errors AprilTag corrects when decoding (its quick-decode table holds every code within
  /// this Hamming distance). tag36h11: 1 bit takes a 1 MB table, 2 bits 36 MB (libapriltag 3.3
  /// sizes it 3 x codes x (1 + n + n(n-1)) entries of 16 bytes for n = 36 bits); the family's
  /// minimum distance of 11 keeps false decodes rare either way. In [0, 3].
  int max_bits_corrected = 1;

  /// Track boards: after a frame with detections, search only crops around them (the tag's bounding
  /// box grown by roi_margin x the tag's size in pixels plus roi_min_margin_px on each side). The
  /// full frame is searched (policy):
  ///  - on the first frame and after ResetTracking();
  ///  - in the same frame, when a tracked board is not found in its crop (lost);
  ///  - when fewer boards than configured are tracked, at most every missing_search_every frames
  ///    (boards entering the view are found then; a board that stays out of view does not make
  ///    every frame a full-frame search);
  ///  - with every configured board tracked, only every full_frame_every frames (0: never: each
  ///    board has its own tag, so no other configured board can be in view). A full-frame search
  ///    at 3840x1920 costs about 10 crop searches.
  bool track_rois = true;
  double roi_margin = 0.6;
  double roi_min_margin_px = 40.0;
  /// Each crop's quad search is decimated by the largest integer factor (up to roi_max_decimate)
  /// that keeps the tag at least this many pixels wide: a 260 px tag at 6 m is searched at 1/5
  /// resolution, a 53 px tag at 30 m at full resolution.
  double roi_min_tag_px = 50.0;
  int roi_max_decimate = 6;
  int full_frame_every = 0;
  int missing_search_every = 3;
  /// Tracking needs a stream: a frame more than this after the previous one, or without a capture
  /// time (still poses, a folder of pairs), is searched whole, so that a board moved or hidden
  /// between still poses is never looked for only where it was, nor skipped.
  double max_stream_gap_s = 0.5;

  /// Reject detections whose PnP reprojection RMS exceeds this (pixels).
  double max_reprojection_rms_px = 2.0;
  /// Reject AprilTag detections with a decision margin below this (weak or false decodes).
  double min_decision_margin = 30.0;

  /// Checkerboards: cv::findChessboardCornersSB runs on the image downscaled by this integer factor
  /// (its cost grows with the pixel count), then cv::cornerSubPix refines at full resolution. A
  /// frame outside a stream (max_stream_gap_s) that shows no board downscaled is searched again
  /// at full resolution: a small or far board's squares vanish when downscaled.
  int checker_downscale = 2;

  /// True when usable; otherwise `error` names the bad field.
  bool IsValid(std::string* error) const;
};

/// One board seen by the camera.
struct BoardDetection2D {
  int board_id = -1;  ///< BoardGeometry::board_id
  /// Tag corners (checkerboard: the 4 outermost inner corners), OpenCV pixel convention, in the
  /// order of BoardGeometry::TagCornersInBoard() (AprilTag's: bottom-left first).
  std::array<Eigen::Vector2d, 4> corners_px;
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();  ///< projection of the board centre
  Pose T_camera_board = Pose::Identity();               ///< from PnP over the corners
  double reprojection_rms_px = 0.0;  ///< of the corners (checkerboard: all inner corners)
  double decision_margin = 0.0;      ///< AprilTag's decision margin (0 for checkerboards)
  BoardOutline outline;  ///< the board's edges against the configured ones (board_outline.hpp)
};

struct CameraDetections {
  std::vector<BoardDetection2D> boards;  ///< capacity = number of configured boards
  bool full_frame_search = false;        ///< this frame searched the whole image
  int rejected = 0;                      ///< candidates dropped (unknown id, margin, PnP error)
};

/// The AprilTag searches of one image, kept for other detectors that search the same image with
/// the same tag family and AprilTag settings (their boards, intrinsics and gates may differ): a
/// window searched once is not searched again. For an evaluation that detects one image under
/// several configurations (calibd-bench verdicts); the agent has one detector per camera and no
/// use for it. Not thread-safe.
class TagSearchMemo {
 public:
  /// One tag as AprilTag reported it: id, decision margin, corners in the window's pixels
  /// (AprilTag's pixel-centre convention).
  struct Tag {
    int id = 0;
    float decision_margin = 0.0f;
    std::array<Eigen::Vector2d, 4> corners;
  };

  /// Forgets every search: call before the detectors see the next image.
  void Clear() { searches_.clear(); }
  /// Searches answered from the memo since it was made.
  int reused() const { return reused_; }

 private:
  friend class CameraDetector;
  struct Search {
    const uint8_t* data = nullptr;  ///< the image's first pixel, and its row stride
    int stride = 0;
    int x0 = 0, y0 = 0, width = 0, height = 0;
    float decimate = 0.0f;
    std::string settings;  ///< tag family and AprilTag settings
    std::vector<Tag> tags;
  };
  std::vector<Search> searches_;
  int reused_ = 0;
};

/// Detects the configured boards in mono8 images (paper §III-B). AprilTag boards must all use one
/// tag family (one AprilTag detector, created once). At most one checkerboard board is supported,
/// searched in every frame without tracking. Not thread-safe: one detector per camera thread.
class CameraDetector {
 public:
  CameraDetector(const CameraDetectorConfig& config, const CameraIntrinsics& intrinsics,
                 const std::vector<BoardGeometry>& boards);
  ~CameraDetector();
  CameraDetector(const CameraDetector&) = delete;
  CameraDetector& operator=(const CameraDetector&) = delete;

  /// False when the config, intrinsics or boards were unusable; error() says why.
  bool ok() const;
  const std::string& error() const;

  /// Detects the configured boards. A frame with no boards (or an empty/null image) gives an empty
  /// result, not an error. `capture_utime` (us) lets the tracking follow a stream
  /// (max_stream_gap_s); without it every frame is searched whole.
  void Detect(const ImageView& image, CameraDetections* out,
              int64_t capture_utime = kUnknownCaptureTime);
  /// Reserves `out` for any frame (one detection per configured board), so that its first
  /// Detect() does not allocate either: for output buffers made at start-up.
  void ReserveOutput(CameraDetections* out) const;

  /// Forgets tracked regions (next frame searches the full image).
  void ResetTracking();

  /// Takes AprilTag's results for a window `memo` holds (same image, family and settings) from
  /// it, and keeps those of the windows it searches there; nullptr (the default): none. The same
  /// detections as without, in less time when another detector searched the image before.
  void UseSearchMemo(TagSearchMemo* memo);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace calibd
