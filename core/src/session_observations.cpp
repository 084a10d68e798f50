#include "calibd/core/session_observations.hpp"

namespace calibd {

void SessionObservations::Reserve(int max_frames, int max_boards, int max_points_per_cluster) {
  max_frames_ = max_frames;
  const size_t entries = static_cast<size_t>(max_frames) * static_cast<size_t>(max_boards);
  camera.reserve(entries);
  lidar.reserve(entries);
  points.reserve(entries * static_cast<size_t>(max_points_per_cluster));
  point_dt.reserve(points.capacity());
  frame_times.reserve(static_cast<size_t>(max_frames));
  Clear();
}

void SessionObservations::Clear() {
  camera.clear();
  lidar.clear();
  points.clear();
  point_dt.clear();
  frame_times.clear();
  num_frames = 0;
}

bool SessionObservations::BeginFrame(const FrameTimes& times) {
  if (num_frames >= max_frames_) return false;
  ++num_frames;
  frame_times.push_back(times);
  return true;
}

bool SessionObservations::AddCameraBoard(const CameraBoard& board) {
  if (num_frames == 0 || camera.size() >= camera.capacity()) return false;
  camera.push_back(board);
  camera.back().frame = num_frames - 1;
  return true;
}

bool SessionObservations::AddLidarCluster(const Eigen::Vector3f* cluster_points,
                                          const float* time_s, int count) {
  if (num_frames == 0 || count <= 0 || lidar.size() >= lidar.capacity() ||
      points.size() + static_cast<size_t>(count) > points.capacity())
    return false;
  LidarCluster c;
  c.frame = num_frames - 1;
  c.first_point = static_cast<int>(points.size());
  c.num_points = count;
  points.insert(points.end(), cluster_points, cluster_points + count);
  const FrameTimes& t = frame_times.back();
  const float sweep_dt =
      static_cast<float>(static_cast<double>(t.lidar_utime - t.camera_utime) * 1e-6);
  for (int i = 0; i < count; ++i) point_dt.push_back(sweep_dt + (time_s ? time_s[i] : 0.0f));
  lidar.push_back(c);
  return true;
}

bool SessionObservations::AddFrame(const CameraDetections& cam, const LidarDetections& lid,
                                   const std::vector<BoardGeometry>& boards,
                                   const FrameTimes& times) {
  if (!BeginFrame(times)) return false;
  bool ok = true;
  for (const auto& d : cam.boards) {
    int index = -1;
    for (size_t i = 0; i < boards.size(); ++i)
      if (boards[i].board_id == d.board_id) index = static_cast<int>(i);
    if (index < 0) continue;
    CameraBoard b;
    b.board_index = index;
    b.T_camera_board = d.T_camera_board;
    b.corners_px = d.corners_px;
    ok = AddCameraBoard(b) && ok;
  }
  for (const auto& c : lid.boards)
    ok = AddLidarCluster(lid.points.data() + c.first_point,
                         lid.point_time_s.size() == lid.points.size()
                             ? lid.point_time_s.data() + c.first_point
                             : nullptr,
                         c.num_points) &&
         ok;
  return ok;
}

}  // namespace calibd
