#include "engine/engine_steps.hpp"

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/session/board_distances.hpp"
#include "calibd/core/verdict/board_swap_check.hpp"

namespace calibd {

namespace {

/// The detail of a `board_ids_swapped` refusal: `claim` boards A and B "are each other's
/// (`evidence`)", and what to do.
std::string SwappedBoardsDetail(const std::vector<BoardGeometry>& boards, const BoardSwap& swap,
                                const std::string& claim, const std::string& evidence) {
  const BoardGeometry& a = boards[static_cast<size_t>(swap.board_a)];
  const BoardGeometry& b = boards[static_cast<size_t>(swap.board_b)];
  auto name = [](const BoardGeometry& g) {
    return std::to_string(g.board_id) + " (tag id " + std::to_string(g.tag_id) + ", " +
           FixedDecimal(g.width_m, 3) + " x " + FixedDecimal(g.height_m, 3) + " m)";
  };
  return claim + " boards " + name(a) + " and " + name(b) + " are each other's (" + evidence +
         "): the configuration gives each of them the other's id or sizes; check which id is "
         "printed on which board and correct the configuration";
}

}  // namespace

Reason CheckInputs(const CalibConfig& config, const SessionObservations& observed,
                   const EngineConfig& engine, std::string* detail) {
  std::string why;
  if (!engine.grid.IsValid(&why) || !engine.motion.IsValid(&why) || !engine.direct.IsValid(&why) ||
      !engine.scenery.IsValid(&why))
    return Refuse(detail, Reason::kInvalidConfig, "engine config: " + why);
  if (observed.lidar_valid_points > 0 &&
      static_cast<double>(observed.lidar_outside_points) >
          kMaxLidarOutsideShare * static_cast<double>(observed.lidar_valid_points))
    return Refuse(
        detail, Reason::kLidarModelMismatch,
        FixedDecimal(100.0 * static_cast<double>(observed.lidar_outside_points) /
                         static_cast<double>(observed.lidar_valid_points),
                     1) +
            " % of the LiDAR's points fall outside the field of view of the configured model (" +
            config.lidar_model +
            "): the clouds come from another LiDAR, or in other axes (x forward, z up), than the "
            "configuration says; configure the model that recorded them (calibd-calibrate "
            "--inspect estimates one), or 'generic'");
  if (observed.camera.empty())
    return Refuse(detail, Reason::kNoCameraBoards,
                  "the camera saw no configured board in any frame pair");
  if (observed.lidar.empty())
    return Refuse(detail, Reason::kNoLidarBoards,
                  "the LiDAR found no board cluster in any frame pair");

  return Reason::kNone;
}

const SessionObservations& WithoutStaticScenery(const SessionObservations& observed,
                                                const StaticScenery& scenery,
                                                SessionObservations* subset) {
  if (scenery.num_scenery == 0) return observed;
  std::vector<char> keep(observed.lidar.size());
  for (size_t j = 0; j < keep.size(); ++j) keep[j] = !scenery.scenery[j];
  *subset = Subset(observed, std::vector<char>(static_cast<size_t>(observed.num_frames), 1),
                   std::vector<char>(observed.camera.size(), 1), keep);
  return *subset;
}

Reason CheckMovingClusters(const SessionObservations& session, const StaticScenery& scenery,
                           std::string* detail) {
  if (!session.lidar.empty()) return Reason::kNone;
  return Refuse(detail, Reason::kNoLidarBoards,
                "every one of the " + std::to_string(scenery.num_scenery) +
                    " LiDAR board clusters stood still while the camera's boards moved "
                    "(furniture or walls, not boards): are the configured board sizes right, "
                    "and do the boards stand free, 0.3 m or more in front of anything?");
}

Reason SearchGrid(const CalibConfig& config, const SessionObservations& session,
                  const RangeImage& projection, const EngineConfig& engine,
                  GridSearchResult* result, ObservationSet* corr, std::string* detail) {
  GridSearch grid(engine.grid, projection, config.boards);
  *result = grid.Run(session, config.prior_T_camera_lidar, corr, engine.max_solve_frames,
                     engine.direct.threads);
  if (result->status != GridSearchResult::Status::kOk) {
    const BoardSwap swap = FindSwappedBoards(engine.grid, projection, config.boards, session,
                                             config.prior_T_camera_lidar, engine.max_solve_frames);
    if (!swap.found) return Refuse(detail, Reason::kNoGridCandidate, result->reason);
    return Refuse(detail, Reason::kBoardIdsSwapped,
                  SwappedBoardsDetail(config.boards, swap, "the LiDAR finds the boards only if",
                                      std::to_string(swap.grid.best_count) +
                                          " LiDAR board points in their regions then, too few "
                                          "without"));
  }
  return Reason::kNone;
}

void NameClustersInTheSession(const SessionObservations& observed, const StaticScenery& scenery,
                              ObservationSet* corr) {
  if (scenery.num_scenery == 0) return;
  std::vector<int> original;
  original.reserve(observed.lidar.size());
  for (size_t j = 0; j < observed.lidar.size(); ++j)
    if (!scenery.scenery[j]) original.push_back(static_cast<int>(j));
  for (BoardObservation& o : corr->observations)
    if (o.lidar_cluster >= 0) o.lidar_cluster = original[static_cast<size_t>(o.lidar_cluster)];
}

Reason CheckCorrespondences(const CalibConfig& config, const VerdictConfig& v,
                            const MotionCompensationStats& motion, const ObservationSet& corr,
                            const Pose& T_camera_lidar, const QualityFigures& q,
                            std::string* detail) {
  const std::string unmeasured =
      motion.dropped == 0
          ? ""
          : " once " + std::to_string(motion.dropped) +
                " whose board's motion the camera could not measure were dropped (the boards "
                "moved by " +
                FixedDecimal(motion.median_shift_m * 1e3, 0) + " mm between the sensors' times)";
  if (const Reason reason = TooFewCorrespondences(q, v, unmeasured, detail);
      reason != Reason::kNone)
    return reason;
  {
    const BoardSwap swap =
        FindSwapInDistances(config.boards, BoardDistances(corr, T_camera_lidar, &config.boards));
    if (swap.found)
      return Refuse(
          detail, Reason::kBoardIdsSwapped,
          SwappedBoardsDetail(config.boards, swap, "the camera's distances say",
                              "it puts them at " + FixedDecimal(swap.ratio_a, 2) + " and " +
                                  FixedDecimal(swap.ratio_b, 2) + " times the LiDAR's"));
  }

  return Reason::kNone;
}

}  // namespace calibd
