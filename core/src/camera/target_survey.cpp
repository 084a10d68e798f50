#include "calibd/core/camera/target_survey.hpp"

#include <apriltag/apriltag.h>

#include <algorithm>
#include <cmath>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

#include "common/apriltag_families.hpp"

namespace calibd {

struct TargetSurvey::Impl {
  TargetSurveyConfig config;
  std::string error;
  apriltag_detector_t* detector = nullptr;
  std::vector<std::pair<const internal::AprilTagFamilyEntry*, apriltag_family_t*>> families;
  cv::Mat small;

  ~Impl() {
    if (detector) apriltag_detector_destroy(detector);
    for (auto& [entry, family] : families) entry->destroy(family);
  }
};

TargetSurvey::TargetSurvey(const TargetSurveyConfig& config) : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  impl_->detector = apriltag_detector_create();
  impl_->detector->quad_decimate = 2.0f;
  // One thread: Debian's libapriltag 3.3 has a race in its worker pool (a worker woken
  // spuriously reads the task list while a task is added and the list reallocated; fixed upstream
  // by AprilRobotics/apriltag#339, 2024), seen here as a segfault in about 1 of 60 runs under
  // qemu-aarch64. A survey of a few images does not need the speed.
  impl_->detector->nthreads = 1;
  for (const std::string& name : config.families) {
    const internal::AprilTagFamilyEntry* entry = internal::FindAprilTagFamily(name);
    if (!entry) {
      impl_->error = "unknown tag family '" + name + "'";
      return;
    }
    apriltag_family_t* family = entry->create();
    impl_->families.emplace_back(entry, family);
    apriltag_detector_add_family_bits(impl_->detector, family, 0);
  }
}

TargetSurvey::~TargetSurvey() = default;

bool TargetSurvey::ok() const { return impl_->error.empty(); }
const std::string& TargetSurvey::error() const { return impl_->error; }

std::vector<TagSighting> TargetSurvey::Tags(const ImageView& image) {
  std::vector<TagSighting> out;
  if (!ok() || image.data == nullptr || image.width <= 0 || image.height <= 0) return out;
  image_u8_t im{image.width, image.height, image.stride, const_cast<uint8_t*>(image.data)};
  zarray_t* detections = apriltag_detector_detect(impl_->detector, &im);
  for (int i = 0; i < zarray_size(detections); ++i) {
    apriltag_detection_t* d = nullptr;
    zarray_get(detections, i, &d);
    if (d->decision_margin < impl_->config.min_decision_margin) continue;
    TagSighting s;
    for (const auto& [entry, family] : impl_->families)
      if (family == d->family) s.family = entry->name;
    s.id = d->id;
    s.decision_margin = d->decision_margin;
    s.centre_px = Eigen::Vector2d(d->c[0], d->c[1]);
    for (int k = 0; k < 4; ++k)
      s.side_px += std::hypot(d->p[(k + 1) % 4][0] - d->p[k][0], d->p[(k + 1) % 4][1] - d->p[k][1]);
    s.side_px /= 4.0;
    out.push_back(s);
  }
  apriltag_detections_destroy(detections);
  std::sort(out.begin(), out.end(), [](const TagSighting& a, const TagSighting& b) {
    return a.decision_margin > b.decision_margin;
  });
  return out;
}

bool TargetSurvey::Checkerboard(const ImageView& image, CheckerSighting* out) {
  if (image.data == nullptr || image.width <= 0 || image.height <= 0) return false;
  const cv::Mat full(image.height, image.width, CV_8UC1, const_cast<uint8_t*>(image.data),
                     static_cast<size_t>(image.stride));
  std::vector<cv::Point2f> corners;
  cv::Mat meta;
  // CALIB_CB_LARGER: the 3 x 3 pattern is a minimum; `meta` holds the grid found.
  const int flags = cv::CALIB_CB_LARGER | cv::CALIB_CB_NORMALIZE_IMAGE;
  double scale = 1.0;
  bool found = false;
  const int f = std::max(1, impl_->config.checker_downscale);
  if (f > 1) {
    cv::resize(full, impl_->small, cv::Size(image.width / f, image.height / f), 0, 0,
               cv::INTER_AREA);
    found = cv::findChessboardCornersSB(impl_->small, cv::Size(3, 3), corners, flags, meta);
    scale = f;
  }
  if (!found) {
    scale = 1.0;
    found = cv::findChessboardCornersSB(full, cv::Size(3, 3), corners, flags, meta);
  }
  if (!found || meta.empty() || corners.size() != static_cast<size_t>(meta.rows * meta.cols))
    return false;
  // Corners run along meta's rows: which of its axes is the image's horizontal?
  const cv::Point2f along = corners[static_cast<size_t>(meta.cols - 1)] - corners[0];
  const bool rows_horizontal = std::abs(along.x) >= std::abs(along.y);
  out->inner_cols = rows_horizontal ? meta.cols : meta.rows;
  out->inner_rows = rows_horizontal ? meta.rows : meta.cols;
  double sum = 0.0;
  int n = 0;
  Eigen::Vector2d centre = Eigen::Vector2d::Zero();
  for (int r = 0; r < meta.rows; ++r)
    for (int c = 0; c < meta.cols; ++c) {
      const cv::Point2f& p = corners[static_cast<size_t>(r * meta.cols + c)];
      centre += Eigen::Vector2d(p.x, p.y);
      if (c + 1 < meta.cols) {
        sum += std::hypot(corners[static_cast<size_t>(r * meta.cols + c + 1)].x - p.x,
                          corners[static_cast<size_t>(r * meta.cols + c + 1)].y - p.y);
        ++n;
      }
    }
  out->square_px = n > 0 ? scale * sum / n : 0.0;
  out->centre_px = scale * centre / static_cast<double>(corners.size()) +
                   Eigen::Vector2d::Constant((scale - 1.0) / 2.0);
  return true;
}

}  // namespace calibd
