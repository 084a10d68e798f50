#pragma once
/// \file
/// Scan geometry of an unknown LiDAR (`lidar.model: generic`) estimated from its point clouds: the
/// field of view and the angular resolution that size the range image of paper §III-C-1, for a
/// sensor described only by its points (no ring index, unknown pattern).
///
/// How (all angles in degrees; azimuth = atan2(y, x), elevation = atan2(z, hypot(x, y)), LiDAR
/// frame x forward, y left, z up):
///
/// - **Field of view**: robust percentiles of the azimuths and elevations
///   (`fov_trim_fraction` cut off at each end: stray returns do not widen the image), widened by
///   one resolution step. The azimuth is a full circle (a spinning sensor) when the largest empty
///   sector is narrower than `full_circle_max_gap_deg`; a sector straddling +-180 deg (a sensor
///   looking backwards) also gets the full circle, since the range image's columns do not wrap
///   otherwise.
/// - **Gaps between neighbouring samples**: the points are cut into azimuth columns, each sorted by
///   elevation; the elevation differences of consecutive points are the *vertical* gaps. Likewise
///   elevation bands sorted by azimuth give the *horizontal* gaps. Differences below
///   `same_line_deg` are points of one scan line (one ring of several firings, a MEMS line seen
///   twice in a column) and are not gaps. The column width is the mean sample spacing
///   sqrt(FOV area / points): wide enough that a column holds every line of a line-scanning
///   pattern, narrow enough that an unstructured pattern (a rosette) does not interleave many
///   passes. The band height is half the vertical resolution just found, so a band holds one line
///   of a MEMS raster whose lines are not aligned in azimuth (two interleaved lines would halve
///   its horizontal gaps). Frames are never pooled before the gaps are taken: MEMS patterns shift
///   from frame to frame and interleaved frames would look twice as fine.
/// - **Resolution = the finest typical gap**: the gaps go into a histogram over a log scale; its
///   runs of occupied bins are the pattern's spacing clusters; the finest run holding at least
///   `min_cluster_fraction` of the gaps wins and its median is the resolution. Not the mean (one
///   sparse outer ring or a dropout doubles a gap) and not the overall mode: patterns are not
///   uniform, and the range image must resolve the densest part where the boards are (OT128:
///   0.125 deg rings in its central band, 0.5 deg outside; Falcon: 0.075 deg lines within +-3 deg
///   of the horizon, 0.2 deg outside). Bins at the finest spacing leave empty rows between the
///   sparser lines, which the segmentation's 4-neighbour BFS (Bogoslavskyi & Stachniss 2016)
///   steps over (LidarDetectorConfig::neighbor_search_cells, 3 cells); bins at the coarse spacing
///   would put two or three dense lines into one cell and lose their points (the cell keeps its
///   nearest point and chains only those within cell_range_tolerance_m). A spacing that varies
///   continuously (the M1's alternating 0.1-0.3 deg MEMS lines) is one cluster, and its median is
///   the average line spacing.
/// - **Phase**: the bins are centred on the samples (circular mean of the angles modulo the
///   resolution). Without it a spinning sensor firing at -180 + k * 0.2 deg would put its columns
///   on the bin edges and rounding would pile two columns into one bin next to an empty one. A
///   full circle gets 360 / round(360 / resolution) so that its columns close up.
///
/// Deterministic (no randomness, fixed summation order); allocates only arrays sized from the
/// input. Its time per sweep: calibd-bench resolution.

#include <string>
#include <vector>

#include "calibd/core/common/image_view.hpp"
#include "calibd/core/lidar/lidar_model.hpp"

namespace calibd {

struct LidarResolutionConfig {
  /// Fraction of the points cut off at each end of the azimuth and elevation ranges. Higher
  /// ignores more stray returns and also more of the genuine edge of the field of view.
  double fov_trim_fraction = 0.001;
  /// An azimuth range without an empty sector this wide is a full circle (spinning sensor).
  double full_circle_max_gap_deg = 20.0;
  /// Angular differences below this are samples of one scan line, not gaps. Must stay below the
  /// finest resolution to be found (0.075 deg on the supported sensors) and above the angular
  /// noise of the reported directions.
  double same_line_deg = 0.02;
  /// Gaps beyond this are holes (sky, occlusion), not spacing.
  double max_gap_deg = 5.0;
  /// The finest spacing cluster must hold at least this fraction of the gaps to count as typical:
  /// lower follows rarer fine spacings (an odd pair of close rings), higher the bulk.
  double min_cluster_fraction = 0.1;
  /// Horizontal gaps spread wider than this (upper over lower quartile) mean a pattern without
  /// scan lines (irregular): about 1 along a spinning sensor's rings, 2 along a MEMS mirror's
  /// sinusoid, 4.8 for a Poisson process (calibd-bench resolution prints each simulated
  /// pattern's). Within a factor 1.3 of it the estimate carries a warning.
  double irregular_gap_spread = 3.0;
  /// Fewer valid points in a frame: the frame is not used.
  int min_points_per_frame = 1000;
  /// Clamps of the result, degrees.
  double min_resolution_deg = 0.03;
  double max_resolution_deg = 2.0;

  /// False with `error` naming the bad field.
  bool IsValid(std::string* error) const;
};

/// The estimated scan geometry, or why there is none.
struct LidarResolutionEstimate {
  bool ok = false;
  std::string error;  ///< why not ok: no frames, too few valid points, no structure found
  double azimuth_resolution_deg = 0.0;
  double elevation_resolution_deg = 0.0;
  /// Field of view, bounds on bin edges (bins centred on the samples).
  double azimuth_min_deg = 0.0, azimuth_max_deg = 0.0;
  double elevation_min_deg = 0.0, elevation_max_deg = 0.0;
  bool full_circle = false;  ///< azimuth covers 360 deg (columns wrap)
  int frames_used = 0;
  int points_used = 0;           ///< valid points of the frames used
  int max_points_per_frame = 0;  ///< valid points of the largest frame used
  int vertical_gaps = 0;         ///< gaps the elevation resolution was chosen from
  int horizontal_gaps = 0;       ///< gaps the azimuth resolution was chosen from
  /// Fraction of the gaps inside the chosen (finest typical) cluster.
  double vertical_cluster_fraction = 0.0, horizontal_cluster_fraction = 0.0;
  /// No scan lines (a rosette, a non-repetitive sweep): the bins are the mean sample spacing
  /// sqrt(field of view / points per frame), square, and the model is non-repetitive
  /// (LidarModel::non_repetitive).
  bool irregular = false;
  int mean_points_per_frame = 0;  ///< valid points per frame used (an irregular pattern's density)
  /// Upper over lower quartile of the horizontal gaps: near 1 along scan lines (2 for a MEMS
  /// mirror's sinusoid), about 4.8 for samples without lines (a Poisson process).
  double horizontal_gap_spread = 0.0;
  /// Set when the estimate is uncertain, in words for the user (what to check or set).
  std::string warning;
};

/// Estimates the scan geometry from `num_frames` frames (one is enough; a few give a steadier
/// field of view). Points that are not finite or nearer than 0.1 m are skipped. The gaps are taken
/// per frame and pooled. Never throws; a bad input gives ok = false with `error`.
LidarResolutionEstimate EstimateLidarResolution(const PointCloudView* frames, size_t num_frames,
                                                const LidarResolutionConfig& config = {});

/// Settings of `lidar.model: generic` (config keys lidar.generic.*). A value left at 0 (both
/// bounds at 0 for a range) is estimated from the data; a set value overrides the estimate.
struct GenericLidarConfig {
  double azimuth_resolution_deg = 0.0;
  double elevation_resolution_deg = 0.0;
  double azimuth_min_deg = 0.0, azimuth_max_deg = 0.0;
  double elevation_min_deg = 0.0, elevation_max_deg = 0.0;
  /// Points per frame the buffers are sized for, once at start-up (an estimate from the first
  /// frames could grow later); points beyond are counted and not looked at.
  int max_points = 400000;
  double frame_rate_hz = 10.0;  ///< sweeps per second (pairing window)
  int estimation_frames = 3;    ///< first LiDAR frames of a session the estimate is taken from
  /// Scan lines or none (a rosette, a non-repetitive sweep: LidarModel::non_repetitive). kAuto
  /// takes the estimate's verdict; without an estimate (the agent) it means lines.
  enum class Pattern { kAuto, kLines, kIrregular } pattern = Pattern::kAuto;
  /// An irregular pattern's returns per frame over its field of view (the density its reference
  /// boards are drawn at); 0: the estimate's.
  int points_per_frame = 0;

  bool azimuth_fov_set() const { return azimuth_min_deg != 0.0 || azimuth_max_deg != 0.0; }
  bool elevation_fov_set() const { return elevation_min_deg != 0.0 || elevation_max_deg != 0.0; }
  /// True when every value is given, so no estimate is needed.
  bool complete() const {
    return azimuth_resolution_deg > 0.0 && elevation_resolution_deg > 0.0 && azimuth_fov_set() &&
           elevation_fov_set() && (pattern != Pattern::kIrregular || points_per_frame > 0);
  }
  /// False with `error` naming the bad key (lidar.generic.*).
  bool IsValid(std::string* error) const;
};

/// The LidarModel of a generic sensor: ringless, the config's values where set, the estimate's
/// elsewhere (`estimate` may be null when config.complete()). False with `error` when a value is
/// missing or the result is not a usable range image.
bool MakeGenericLidarModel(const GenericLidarConfig& config,
                           const LidarResolutionEstimate* estimate, LidarModel* model,
                           std::string* error);

/// The model of `lidar.model` without frames to look at (the agent, sized once at start-up): the
/// built-in model, or for "generic" the lidar.generic.* values, which must then all be given.
bool LidarModelFromConfig(const std::string& name, const GenericLidarConfig& generic,
                          LidarModel* model, std::string* error);

/// One line for the user: "generic LiDAR: azimuth 0.200 deg, elevation 0.125 deg, FOV azimuth
/// [-180.0, 180.0] deg, elevation [-25.1, 14.5] deg (estimated from 3 frames, 690000 points)".
std::string DescribeGenericLidar(const LidarModel& model, const LidarResolutionEstimate* estimate);

}  // namespace calibd
