#include "calibd/core/session_observations.hpp"
#include <cassert>

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

SessionObservations Subset(const SessionObservations& s, const std::vector<char>& keep_frame,
                           const std::vector<char>& keep_camera,
                           const std::vector<char>& keep_lidar) {
  // Capacities: kept frames, the most kept entries of one frame, the largest kept cluster.
  std::vector<int> camera_per_frame(static_cast<size_t>(s.num_frames), 0);
  std::vector<int> lidar_per_frame(camera_per_frame.size(), 0);
  int max_points = 1;
  for (size_t i = 0; i < s.camera.size(); ++i)
    if (keep_camera[i]) ++camera_per_frame[static_cast<size_t>(s.camera[i].frame)];
  for (size_t j = 0; j < s.lidar.size(); ++j) {
    if (!keep_lidar[j]) continue;
    ++lidar_per_frame[static_cast<size_t>(s.lidar[j].frame)];
    max_points = std::max(max_points, s.lidar[j].num_points);
  }
  int frames = 0, max_entries = 1;
  for (size_t f = 0; f < camera_per_frame.size(); ++f) {
    if (!keep_frame[f]) continue;
    ++frames;
    max_entries = std::max({max_entries, camera_per_frame[f], lidar_per_frame[f]});
  }

  SessionObservations out;
  out.Reserve(frames, max_entries, max_points);
  std::vector<float> time_s;
  size_t i = 0, j = 0;  // camera and lidar entries are in frame order
  for (int f = 0; f < s.num_frames; ++f) {
    const bool keep = keep_frame[static_cast<size_t>(f)] != 0;
    const FrameTimes& t = s.frame_times[static_cast<size_t>(f)];
    [[maybe_unused]] bool ok = !keep || out.BeginFrame(t);
    // AddLidarCluster takes firing times after the sweep start; the store keeps them relative to
    // the camera time (point_dt = sweep start - camera time + firing time).
    const float sweep_dt =
        static_cast<float>(static_cast<double>(t.lidar_utime - t.camera_utime) * 1e-6);
    for (; i < s.camera.size() && s.camera[i].frame == f; ++i)
      if (keep && keep_camera[i]) ok = out.AddCameraBoard(s.camera[i]) && ok;
    for (; j < s.lidar.size() && s.lidar[j].frame == f; ++j) {
      if (!keep || !keep_lidar[j]) continue;
      const auto& c = s.lidar[j];
      const auto first = static_cast<size_t>(c.first_point);
      time_s.resize(static_cast<size_t>(c.num_points));
      for (size_t p = 0; p < time_s.size(); ++p) time_s[p] = s.point_dt[first + p] - sweep_dt;
      ok = out.AddLidarCluster(s.points.data() + first, time_s.data(), c.num_points) && ok;
    }
    assert(ok && "capacities are sized to fit");
  }
  return out;
}

}  // namespace calibd
