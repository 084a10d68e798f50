#include "calibd/core/session_observations.hpp"

namespace calibd {

void SessionObservations::Reserve(int max_frames, int max_boards, int max_points_per_cluster) {
  max_frames_ = max_frames;
  const size_t entries = static_cast<size_t>(max_frames) * static_cast<size_t>(max_boards);
  camera.reserve(entries);
  lidar.reserve(entries);
  points.reserve(entries * static_cast<size_t>(max_points_per_cluster));
  Clear();
}

void SessionObservations::Clear() {
  camera.clear();
  lidar.clear();
  points.clear();
  num_frames = 0;
}

bool SessionObservations::BeginFrame() {
  if (num_frames >= max_frames_) return false;
  ++num_frames;
  return true;
}

bool SessionObservations::AddCameraBoard(const CameraBoard& board) {
  if (num_frames == 0 || camera.size() >= camera.capacity()) return false;
  camera.push_back(board);
  camera.back().frame = num_frames - 1;
  return true;
}

bool SessionObservations::AddLidarCluster(const Eigen::Vector3f* cluster_points, int count) {
  if (num_frames == 0 || count <= 0 || lidar.size() >= lidar.capacity() ||
      points.size() + static_cast<size_t>(count) > points.capacity())
    return false;
  LidarCluster c;
  c.frame = num_frames - 1;
  c.first_point = static_cast<int>(points.size());
  c.num_points = count;
  points.insert(points.end(), cluster_points, cluster_points + count);
  lidar.push_back(c);
  return true;
}

bool SessionObservations::AddFrame(const CameraDetections& cam, const LidarDetections& lid,
                                   const std::vector<BoardGeometry>& boards) {
  if (!BeginFrame()) return false;
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
    ok = AddLidarCluster(lid.points.data() + c.first_point, c.num_points) && ok;
  return ok;
}

}  // namespace calibd
