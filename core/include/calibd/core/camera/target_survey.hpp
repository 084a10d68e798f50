#pragma once
/// \file
/// What calibration targets an image shows, before any board is configured (calibd-calibrate
/// --inspect): every AprilTag of the common families, with its id and size, and a checkerboard
/// of any size (OpenCV's findChessboardCornersSB with CALIB_CB_LARGER reports the grid it found).

#include <Eigen/Core>
#include <memory>
#include <string>
#include <vector>

#include "calibd/core/common/image_view.hpp"

namespace calibd {

struct TagSighting {
  std::string family;
  int id = 0;
  double side_px = 0.0;  ///< mean side of the tag's black square in the image
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
  double decision_margin = 0.0;
};

struct CheckerSighting {
  /// Inner corners along the image's horizontal and vertical (checker_inner_cols / _rows of an
  /// upright board).
  int inner_cols = 0, inner_rows = 0;
  double square_px = 0.0;  ///< mean distance between neighbouring corners
  Eigen::Vector2d centre_px = Eigen::Vector2d::Zero();
};

struct TargetSurveyConfig {
  /// Families looked for, all in one detector (tag16h5 is left out: its 30 codes match clutter).
  std::vector<std::string> families = {"tag36h11", "tag25h9", "tagStandard41h12", "tag36h10"};
  double min_decision_margin = 30.0;  ///< weaker decodes are noise
  int checker_downscale = 2;          ///< the checkerboard search runs on a smaller copy first
};

class TargetSurvey {
 public:
  explicit TargetSurvey(const TargetSurveyConfig& config = {});
  ~TargetSurvey();
  TargetSurvey(const TargetSurvey&) = delete;
  TargetSurvey& operator=(const TargetSurvey&) = delete;

  /// False with error() when a family is unknown.
  bool ok() const;
  const std::string& error() const;

  /// Every tag in a mono8 image (without corrected bits), strongest first.
  std::vector<TagSighting> Tags(const ImageView& image);
  /// The largest checkerboard in a mono8 image (at least 3 x 3 inner corners); false when none.
  bool Checkerboard(const ImageView& image, CheckerSighting* out);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace calibd
