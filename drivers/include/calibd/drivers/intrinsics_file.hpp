#pragma once
/// \file
/// Camera intrinsics from the files other tools write, to override the calibration config's:
///  - OpenCV FileStorage YAML (`%YAML:1.0`, as cv::FileStorage and OpenCV's calibration samples
///    write it), read with yaml-cpp after its `%YAML:1.0` line (OpenCV's own reader hangs on
///    some malformed files): `camera_matrix` or `K` (3x3 !!opencv-matrix),
///    `distortion_coefficients`, `D` or `dist_coeffs`, `image_width`/`image_height` (or
///    `width`/`height`), optional `distortion_model`;
///  - ROS `camera_info` YAML (camera_calibration's ost.yaml; plain YAML, read with yaml-cpp
///    like the config):
///    `camera_matrix.data` (9 numbers), `distortion_coefficients.data`, `distortion_model`,
///    `image_width`, `image_height`; the same keys as plain lists are accepted too. A matrix
///    map's `rows` x `cols` (at most 16 each) must match its data;
///  - JSON (first character `{`): {"K": 3x3 or 9 numbers, "D": [...], "width", "height",
///    optional "distortion_model"} (`camera_matrix`, `image_width`... accepted as aliases).
///
/// Distortion models: `plumb_bob` / `radtan` (default; D = k1 k2 p1 p2 [k3]),
/// `rational_polynomial` (8 numbers; accepted when k4 k5 k6 are 0, since calibd's camera model has
/// no rational terms), `equidistant` / `fisheye` / `kannala_brandt` (D = k1 k2 k3 k4, OpenCV's
/// cv::fisheye). OpenCV's longer D vectors (8, 12, 14) are accepted when everything past k3 is 0.
/// The camera matrix must be [fx 0 cx; 0 fy cy; 0 0 1] (no skew).

#include <string>

#include "calibd/core/camera/camera_model.hpp"

namespace calibd {

/// Parses intrinsics text; `name` (the file's path) starts every error, which names the key.
bool ParseIntrinsics(const std::string& text, const std::string& name, CameraIntrinsics* intrinsics,
                     std::string* error);

/// Reads `path` and parses it (see ParseIntrinsics); the result passes CameraIntrinsics::IsValid.
bool LoadIntrinsicsFile(const std::string& path, CameraIntrinsics* intrinsics, std::string* error);

}  // namespace calibd
