#include "session.hpp"

#include <cmath>
#include <random>

#include "calibd/core/common/validation.hpp"

namespace calibd::sim {

namespace {

Pose MountPose(const Eigen::Matrix<double, 6, 1>& m) {
  return PoseFromXyzRpy(m.head<3>(), m.tail<3>() * kDeg2Rad);
}

// Optical frame (x right, y down, z forward) in the camera body frame (x forward, y left, z up).
Eigen::Matrix3d R_body_optical() {
  Eigen::Matrix3d R;
  R.col(0) = -Eigen::Vector3d::UnitY();
  R.col(1) = -Eigen::Vector3d::UnitZ();
  R.col(2) = Eigen::Vector3d::UnitX();
  return R;
}

// SplitMix64: decorrelated per-frame seeds from (session seed, frame, stream).
/// Carried boards (StillPoseOptions::board_speed_mps): the LiDAR's sweep is cast into the scene
/// at this many instants, each beam at the nearest to its firing time (LidarSimulator::Scan).
constexpr int kBoardMotionSlices = 10;
/// A rolling shutter (SessionOptions::camera_readout_us) is traced in this many bands of rows,
/// each from the camera's pose at its middle row (10 rows of a 1200-row image: 0.1 px of shift
/// at most at 2.5 m/s, 40 ms, 4 m).
constexpr int kRollingShutterBands = 120;

uint64_t Mix(uint64_t seed, uint64_t k, uint64_t stream) {
  uint64_t z = seed + 0x9e3779b97f4a7c15ULL * (k * 4 + stream + 1);
  z = (z ^ (z >> 30)) * 0xbf58476d1ce4e5b9ULL;
  z = (z ^ (z >> 27)) * 0x94d049bb133111ebULL;
  return z ^ (z >> 31);
}

// True when the printed side faces the camera and `points_board` (board frame) project into the
// image grown by `margin_px` (CameraModel::Project: negative keeps them that far inside).
template <typename Points>
bool FacesCameraInImage(const CameraModel& camera, const Pose& T_camera_board,
                        const Points& points_board, double margin_px) {
  if (T_camera_board.linear().col(2).dot(-T_camera_board.translation()) <= 0.0) return false;
  Eigen::Vector2d uv;
  for (const Eigen::Vector3d& p : points_board)
    if (!camera.Project(T_camera_board * p, &uv, margin_px)) return false;
  return true;
}

}  // namespace

bool SessionOptions::IsValid(std::string* error) const {
  if (!workshop.IsValid(error) || !trajectory.IsValid(error)) return false;
  LidarKind kind;
  if (!LidarKindFromName(lidar_model, &kind, error)) return false;
  if (kind == LidarKind::kGeneric)
    return Invalid(error, "--lidar: the simulator needs a scan pattern, any model but generic (" +
                              LidarModelNames() +
                              "; calibrate a simulated session with lidar.model: generic instead)");
  std::string why;
  if (!camera.IsValid(&why)) return Invalid(error, "camera intrinsics: " + why);
  if (!(stills.min_distance_m >= 0.5 && stills.max_distance_m > stills.min_distance_m &&
        stills.max_distance_m <= 60.0))
    return Invalid(error, "--still-distance must satisfy 0.5 <= min < max <= 60 m");
  if (!(stills.frames_per_pose >= 1 && stills.frames_per_pose <= 100))
    return Invalid(error, "--frames-per-pose must be in [1, 100]");
  if (!(stills.occluded_share >= 0.0 && stills.occluded_share <= 0.5))
    return Invalid(error, "--occluded-share must be in [0, 0.5]");
  if (!(stills.board_speed_mps >= 0.0 && stills.board_speed_mps <= 3.0))
    return Invalid(error, "--board-speed must be in [0, 3] m/s");
  if (trajectory.mode == "stills" && stills.frames_per_pose > 1 && kind != LidarKind::kGeneric &&
      (stills.frames_per_pose - 1) / MakeLidarModel(kind).frame_rate_hz >= 1.0 / trajectory.rate_hz)
    return Invalid(error,
                   "--frames-per-pose: the sweeps of one pose must end before the next pose "
                   "(lower --rate or the frames per pose)");
  if (!(std::abs(prior_rot_deg) <= 10.0))
    return Invalid(error, "--prior-rot-deg must be within +-10 deg");
  if (!(std::abs(prior_trans_m) <= 0.5))
    return Invalid(error, "--prior-trans-m must be within +-0.5 m");
  if (!(lidar_noise.range_sigma_m >= 0.0 && lidar_noise.range_sigma_m <= 0.5))
    return Invalid(error, "--range-noise must be in [0, 0.5] m");
  if (!(std::abs(lidar_noise.range_bias_m) <= 1.0))
    return Invalid(error, "--range-bias must be within +-1 m");
  if (!(std::abs(camera_delay_us) <= 1000000))
    return Invalid(error, "--camera-delay-us must be within +-1 s");
  if (!(camera_readout_us >= 0 && camera_readout_us <= 200000))
    return Invalid(error, "--camera-readout-us must be in [0, 200000]");
  if (!(lidar_noise.dropout_probability >= 0.0 && lidar_noise.dropout_probability < 1.0))
    return Invalid(error, "--dropout must be in [0, 1)");
  if (!(imaging.noise_sigma >= 0.0 && imaging.blur_sigma_px >= 0.0))
    return Invalid(error, "--image-noise and --blur must be >= 0");
  if (image_encoding != "mono8" && image_encoding != "jpeg")
    return Invalid(error, "--image-encoding must be mono8 or jpeg (got '" + image_encoding + "')");
  if (jpeg_quality < 1 || jpeg_quality > 100)
    return Invalid(error, "--jpeg-quality must be in [1, 100]");
  if (camera_id.empty() || lidar_id.empty())
    return Invalid(error, "--camera-id and --lidar-id must not be empty");
  return true;
}

bool SessionSimulator::Init(const SessionOptions& options, std::string* error) {
  if (!options.IsValid(error)) return false;
  options_ = options;
  const bool stills = options.trajectory.mode == "stills";
  if (!stills && !BuildWorkshop(options.workshop, options.seed, &workshop_, error)) return false;
  LidarKind kind;
  LidarKindFromName(options.lidar_model, &kind, nullptr);
  lidar_.emplace(MakeLidarModel(kind), options.lidar_noise);
  camera_.emplace(options.camera, options.imaging);

  T_vehicle_lidar_ = MountPose(options.lidar_mount);
  T_vehicle_camera_ = MountPose(options.camera_mount);
  T_vehicle_camera_.linear() = T_vehicle_camera_.linear() * R_body_optical();
  T_camera_lidar_ = T_vehicle_camera_.inverse() * T_vehicle_lidar_;
  // Every still pose is placed now, so that SimulateFrame cannot fail later.
  still_poses_.clear();
  last_frame_ = 0;
  if (stills && !BuildStillPoses(error)) return false;

  std::mt19937_64 rng(Mix(options.seed, 0, 3));
  std::normal_distribution<double> n01(0.0, 1.0);
  // Three draws z first: function arguments are unsequenced, and z, y, x is the order GCC
  // evaluated Vector3d(n01(rng), n01(rng), n01(rng)) in, which the sessions were made with.
  const auto draw3 = [&] {
    const double z = n01(rng), y = n01(rng), x = n01(rng);
    return Eigen::Vector3d(x, y, z);
  };
  Eigen::Vector3d axis = options.prior_rot_axis;
  if (axis.norm() < 1e-9) axis = draw3();
  const Eigen::Vector3d dir = draw3();
  Pose dT = Pose::Identity();
  dT.linear() = RotationFromAxisAngle(axis, options.prior_rot_deg * kDeg2Rad);
  dT.translation() = dir.normalized() * options.prior_trans_m;
  prior_T_camera_lidar_ = T_camera_lidar_ * dT;

  // Phase: mean firing time of the beams looking along the camera's optical axis.
  const Eigen::Vector3d axis_lidar =
      T_camera_lidar_.linear().transpose() * Eigen::Vector3d::UnitZ();
  const double cam_az = std::atan2(axis_lidar.y(), axis_lidar.x());
  std::vector<Beam> beams;
  MakeScanPattern(lidar_->model(), 0, &beams);
  double sum = 0.0;
  int count = 0;
  for (const Beam& b : beams) {
    if (std::abs(std::remainder(b.azimuth_rad - cam_az, 2.0 * M_PI)) < 2.0 * kDeg2Rad) {
      sum += b.time_offset_us;
      ++count;
    }
  }
  const double period_us = 1e6 / lidar_->model().frame_rate_hz;
  camera_phase_us_ = count > 0 ? static_cast<int64_t>(std::llround(sum / count))
                               : static_cast<int64_t>(period_us / 2);
  return true;
}

bool SessionSimulator::BuildStillPoses(std::string* error) {
  const Pose T_world_vehicle =
      VehiclePoseAt(options_.trajectory, T_vehicle_lidar_.translation().x(), 0.0);
  const Pose T_world_camera = T_world_vehicle * T_vehicle_camera_;
  // Usable by the camera: printed side towards it and every board vertex 20 px inside the image.
  auto visible = [&](const Pose& T_world_board, const BoardGeometry& g) {
    return FacesCameraInImage(camera_->model(), T_world_camera.inverse() * T_world_board,
                              g.BoardVerticesInBoard(), -20.0);
  };
  const int poses = options_.trajectory.num_frames();
  still_poses_.resize(static_cast<size_t>(poses));
  for (int k = 0; k < poses; ++k)
    if (!BuildStillPose(options_.workshop, options_.stills, lidar_->model(),
                        T_world_vehicle * T_vehicle_lidar_, visible, options_.seed, k,
                        &still_poses_[static_cast<size_t>(k)], error))
      return false;
  return true;
}

void SessionSimulator::SimulateFrame(int k, cv::Mat* image, LidarScan* scan, FrameTruth* truth) {
  const auto& traj = options_.trajectory;
  // Stills: frames_per_pose frames a sweep apart per pose, the poses 1 / rate_hz apart.
  const int per_pose = still_poses_.empty() ? 1 : options_.stills.frames_per_pose;
  last_frame_ = still_poses_.empty() ? 0 : k / per_pose;
  Workshop& workshop = still_poses_.empty() ? workshop_ : still_poses_[last_frame_];
  const double lidar_x = T_vehicle_lidar_.translation().x();
  const int64_t frame_period_us = static_cast<int64_t>(std::llround(1e6 / traj.rate_hz));
  const int64_t sweep_period_us =
      static_cast<int64_t>(std::llround(1e6 / lidar_->model().frame_rate_hz));
  const int64_t trigger_utime =
      options_.start_utime + (k / per_pose) * frame_period_us + (k % per_pose) * sweep_period_us;
  const int64_t lidar_utime = trigger_utime - camera_phase_us_;
  const int64_t camera_utime = trigger_utime + options_.camera_delay_us;
  const double sweep_s = 1.0 / lidar_->model().frame_rate_hz;
  auto seconds = [&](int64_t utime) {
    return static_cast<double>(utime - options_.start_utime) * 1e-6;
  };

  const Pose T_world_vehicle_cam = VehiclePoseAt(traj, lidar_x, seconds(camera_utime));
  const Pose T_world_camera = T_world_vehicle_cam * T_vehicle_camera_;
  const Pose T_world_lidar_start =
      VehiclePoseAt(traj, lidar_x, seconds(lidar_utime)) * T_vehicle_lidar_;
  const Pose T_world_lidar_end =
      VehiclePoseAt(traj, lidar_x, seconds(lidar_utime) + sweep_s) * T_vehicle_lidar_;

  // Boards still carried (StillPoseOptions::board_speed_mps): moved to where they are at a
  // sensor's time, each LiDAR beam's when it fires, the camera's when it exposes (the truth's
  // LiDAR board pose: when the beams along the camera's axis fire, at the trigger); put back
  // after the frame.
  const double speed = still_poses_.empty() ? 0.0 : options_.stills.board_speed_mps;
  const size_t num_boards = workshop.scene.boards.size();
  std::vector<Pose> placed(num_boards), slabs(num_boards);
  std::vector<Eigen::Vector3d> velocity(num_boards, Eigen::Vector3d::Zero());
  const int64_t pose_utime = options_.start_utime + (k / per_pose) * frame_period_us;
  for (size_t b = 0; b < num_boards && speed > 0.0; ++b) {
    placed[b] = workshop.scene.boards[b].T_world_board;
    slabs[b] = workshop.scene.primitives[workshop.scene.boards[b].primitive_index].T_world_local;
    std::mt19937_64 rng(Mix(options_.seed, k / per_pose, 4 + static_cast<uint64_t>(b)));
    const double heading = std::uniform_real_distribution<double>(-M_PI, M_PI)(rng);
    velocity[b] = speed * Eigen::Vector3d(std::cos(heading), std::sin(heading), 0.0);
  }
  auto move_boards_to = [&](int64_t utime) {
    if (speed <= 0.0) return;
    const double dt = static_cast<double>(utime - pose_utime) * 1e-6;
    for (size_t b = 0; b < num_boards; ++b) {
      PlacedBoard& board = workshop.scene.boards[b];
      board.T_world_board = placed[b];
      board.T_world_board.translation() += velocity[b] * dt;
      Pose& slab = workshop.scene.primitives[board.primitive_index].T_world_local;
      slab = slabs[b];
      slab.translation() += velocity[b] * dt;
    }
    workshop.scene.Finalize();
  };
  if (scan == nullptr) {
    // No sweep asked for (the caller takes one simulated with the same scene and seed).
  } else if (speed > 0.0) {
    // The LiDAR fires over its whole sweep, a MEMS sensor down a board over most of it: the
    // beams see the boards where they are at their own time (kBoardMotionSlices of the sweep).
    std::vector<Scene> slices(kBoardMotionSlices);
    std::vector<const Scene*> pointers;
    for (int j = 0; j < kBoardMotionSlices; ++j) {
      move_boards_to(lidar_utime + (2 * j + 1) * sweep_period_us / (2 * kBoardMotionSlices));
      slices[static_cast<size_t>(j)] = workshop.scene;
      pointers.push_back(&slices[static_cast<size_t>(j)]);
    }
    lidar_->Scan(pointers, T_world_lidar_start, T_world_lidar_end, k, Mix(options_.seed, k, 2),
                 scan);
  } else {
    lidar_->Scan(workshop.scene, T_world_lidar_start, T_world_lidar_end, k,
                 Mix(options_.seed, k, 2), scan);
  }
  std::vector<Pose> T_lidar_board(num_boards);
  move_boards_to(trigger_utime);
  for (size_t b = 0; b < num_boards; ++b)
    T_lidar_board[b] = T_world_lidar_start.inverse() * workshop.scene.boards[b].T_world_board;
  move_boards_to(camera_utime);
  if (image) {
    // A still pose's later frames see the same scene from the same place: traced once (unless
    // its boards move).
    const uint64_t seed = Mix(options_.seed, k, 1);
    const bool repeat = k % per_pose != 0 && k == last_rendered_ + 1 && speed <= 0.0;
    if (options_.camera_readout_us > 0) {
      const double first_row_s = seconds(camera_utime);
      const double readout_s = static_cast<double>(options_.camera_readout_us) * 1e-6;
      auto T_world_camera_at = [&](double row_share) -> Pose {
        return VehiclePoseAt(traj, lidar_x, first_row_s + row_share * readout_s) *
               T_vehicle_camera_;
      };
      camera_->Render(workshop.scene, workshop.faces, T_world_camera_at, kRollingShutterBands, seed,
                      image);
    } else if (!repeat || !camera_->RenderRepeat(seed, image)) {
      camera_->Render(workshop.scene, workshop.faces, T_world_camera, seed, image);
    }
    last_rendered_ = k;
  }

  truth->index = k;
  truth->camera_utime = camera_utime;
  truth->lidar_utime = lidar_utime;
  truth->T_world_vehicle = T_world_vehicle_cam;
  truth->boards.resize(workshop.scene.boards.size());
  for (size_t b = 0; b < workshop.scene.boards.size(); ++b) {
    BoardTruth& bt = truth->boards[b];
    const Pose& T_world_board = workshop.scene.boards[b].T_world_board;
    bt.board_id = workshop.geometries[b].board_id;
    bt.T_camera_board = T_world_camera.inverse() * T_world_board;
    bt.T_lidar_board = T_lidar_board[b];
    // The tag is usable when it faces the camera and all corners land 2 px inside the image.
    bt.tag_in_image = FacesCameraInImage(camera_->model(), bt.T_camera_board,
                                         workshop.geometries[b].TagCornersInBoard(), -2.0);
    bt.lidar_point_indices.clear();
  }
  for (size_t i = 0; scan != nullptr && i < scan->size(); ++i) {
    const int b = scan->board[i];
    if (b >= 0) truth->boards[b].lidar_point_indices.push_back(static_cast<int>(i));
  }
  move_boards_to(pose_utime);  // back where the pose placed them
}

CalibConfig SessionSimulator::UserConfig() const {
  CalibConfig c;
  c.camera_id = options_.camera_id;
  c.camera = options_.camera;
  c.principal_point_sigma_px = options_.stated_principal_point_sigma_px;
  c.lidar_id = options_.lidar_id;
  c.lidar_model = options_.lidar_model;
  c.boards = workshop().geometries;
  c.prior_T_camera_lidar = prior_T_camera_lidar_;
  return c;
}

}  // namespace calibd::sim
