#pragma once
/// \file
/// calibd-calibrate's pictures of its result (--overlay DIR, and the HTML report's): up to four
/// frame pairs spread over the boards' distances, the LiDAR points projected through the result,
/// the detected tag corners in green and the LiDAR-fitted ones in red.

#include <functional>
#include <string>
#include <vector>

#include "calibration_run.hpp"
#include "html_report.hpp"

namespace calibd::tools {

/// Reads again the pairs listed (their images and points, LogReadOptions::detect off) into
/// `kept`; false with `error`.
using PairReader = std::function<bool(const std::vector<int>& pairs,
                                      std::vector<FramePairData>* kept, std::string* error)>;

/// Up to 4 frame pairs spread over the camera-to-board distances of the correspondences.
std::vector<int> PictureFrames(const ObservationSet& correspondences);

/// Draws the pictures of `run`: written as `overlay_dir`/pair_<n>.png when `overlay_dir` is not
/// empty (created), and appended to `images` when not null. False with `error` when a pair cannot
/// be read or a picture written.
bool DrawResultPictures(const CalibrationRun& run, const CalibConfig& config,
                        const EngineConfig& engine, const PairReader& read_pairs,
                        const std::string& overlay_dir, std::vector<ReportImage>* images,
                        std::string* error);

}  // namespace calibd::tools
