#pragma once
/// \file
/// Board pose from image corners (paper §III-B: "T_B^C can then be estimated using the PnP
/// algorithm"). One code path for every distortion model: the corners are undistorted with
/// CameraModel::Unproject into normalised coordinates, then OpenCV's PnP runs with an identity
/// camera matrix and no distortion, and the reprojection error is measured in pixels through
/// CameraModel.

#include <Eigen/Core>
#include <array>
#include <vector>

#include "calibd/core/camera/camera_model.hpp"
#include "calibd/core/common/board.hpp"
#include "calibd/core/common/geometry.hpp"

namespace calibd {

/// T_camera_board from the 4 corners of a square tag, in the order of
/// BoardGeometry::TagCornersInBoard() (OpenCV pixel convention): IPPE (Collins & Bartoli 2014, the
/// method of OpenCV's SOLVEPNP_IPPE_SQUARE) then Levenberg-Marquardt refinement of the normalised
/// reprojection error, both in fixed-size Eigen: no heap allocation (it runs for every tag of
/// every frame). False when a corner cannot be undistorted or PnP fails; `reprojection_rms_px`
/// (optional) is the RMS of the 4 corners under the pose. For a checkerboard board the 4 outer
/// inner corners are a rectangle, not a square: use EstimatePlanarPose.
bool EstimateTagPose(const CameraModel& model, const BoardGeometry& board,
                     const std::array<Eigen::Vector2d, 4>& corners_px, Pose* T_camera_board,
                     double* reprojection_rms_px);

/// T_camera_board from n >= 4 coplanar points (z_B = 0) and their pixels (checkerboard inner
/// corners): SOLVEPNP_ITERATIVE (homography initialisation) then Levenberg-Marquardt refinement.
/// OpenCV's: allocates (as does the checkerboard search before it).
bool EstimatePlanarPose(const CameraModel& model, const std::vector<Eigen::Vector3d>& points_board,
                        const std::vector<Eigen::Vector2d>& points_px, Pose* T_camera_board,
                        double* reprojection_rms_px);

/// RMS in pixels of `points_board` projected through `model` under T_camera_board against
/// `points_px`; infinity if a point lies behind the camera.
double ReprojectionRmsPx(const CameraModel& model, const Pose& T_camera_board,
                         const Eigen::Vector3d* points_board, const Eigen::Vector2d* points_px,
                         size_t n);

}  // namespace calibd
