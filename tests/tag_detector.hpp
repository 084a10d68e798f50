#pragma once
// Test-only AprilTag detector in RAII (the C objects never escape it), reporting corners in
// OpenCV's pixel convention. The product's camera detector lives in core/ (detection issue).

#include <apriltag/apriltag.h>
#include <apriltag/common/zarray.h>
#include <apriltag/tag36h11.h>

#include <Eigen/Core>
#include <array>
#include <memory>
#include <opencv2/core.hpp>
#include <vector>

namespace calibd::testing {

// ---- AprilTag in RAII (the C objects never escape this block) ----
struct FamilyDeleter {
  void (*destroy)(apriltag_family_t*) = tag36h11_destroy;
  void operator()(apriltag_family_t* f) const { destroy(f); }
};
struct DetectorDeleter {
  void operator()(apriltag_detector_t* d) const { apriltag_detector_destroy(d); }
};
struct DetectionsDeleter {
  void operator()(zarray_t* z) const { apriltag_detections_destroy(z); }
};

struct Detection {
  int id = -1;
  std::array<Eigen::Vector2d, 4> corners;  ///< OpenCV pixel convention, AprilTag's order
};

class TagDetector {
 public:
  explicit TagDetector(apriltag_family_t* (*create)() = tag36h11_create,
                       void (*destroy)(apriltag_family_t*) = tag36h11_destroy)
      : family_(create(), FamilyDeleter{destroy}), detector_(apriltag_detector_create()) {
    apriltag_detector_add_family(detector_.get(), family_.get());
    detector_->quad_decimate = 1.0f;
    detector_->refine_edges = true;
    detector_->nthreads = 2;
  }

  std::vector<Detection> Detect(const cv::Mat& mono8) const {
    image_u8_t im{mono8.cols, mono8.rows, static_cast<int32_t>(mono8.step[0]), mono8.data};
    std::unique_ptr<zarray_t, DetectionsDeleter> dets(
        apriltag_detector_detect(detector_.get(), &im));
    std::vector<Detection> out;
    for (int i = 0; i < zarray_size(dets.get()); ++i) {
      apriltag_detection_t* d = nullptr;
      zarray_get(dets.get(), i, &d);
      Detection det;
      det.id = d->id;
      // AprilTag reports pixel centres at i + 0.5 (docs/conventions.md#apriltag-pixels); our
      // convention is OpenCV's.
      for (int k = 0; k < 4; ++k) det.corners[k] = {d->p[k][0] - 0.5, d->p[k][1] - 0.5};
      out.push_back(det);
    }
    return out;
  }

 private:
  std::unique_ptr<apriltag_family_t, FamilyDeleter> family_;  // outlives the detector
  std::unique_ptr<apriltag_detector_t, DetectorDeleter> detector_;
};

}  // namespace calibd::testing
