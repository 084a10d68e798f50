#include "calibd/core/session/session_observations.hpp"
#include <algorithm>
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
  lidar_valid_points = lidar_outside_points = 0;
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
  lidar_valid_points += lid.cloud_points - lid.overflow_points - lid.invalid_points;
  lidar_outside_points += lid.outside_points;
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
    b.outline = d.outline;
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

SessionObservations SelectFrames(const SessionObservations& s, const std::vector<int>& frames,
                                 const std::vector<char>& keep_camera,
                                 const std::vector<char>& keep_lidar,
                                 std::vector<int>* source_lidar) {
  if (source_lidar) source_lidar->clear();
  // Entries are in frame order: the first camera and LiDAR entry of every frame.
  std::vector<size_t> first_camera(static_cast<size_t>(s.num_frames) + 1, s.camera.size());
  std::vector<size_t> first_lidar(first_camera.size(), s.lidar.size());
  for (size_t i = s.camera.size(); i-- > 0;)
    first_camera[static_cast<size_t>(s.camera[i].frame)] = i;
  for (size_t j = s.lidar.size(); j-- > 0;) first_lidar[static_cast<size_t>(s.lidar[j].frame)] = j;
  for (size_t f = first_camera.size() - 1; f-- > 0;) {
    first_camera[f] = std::min(first_camera[f], first_camera[f + 1]);
    first_lidar[f] = std::min(first_lidar[f], first_lidar[f + 1]);
  }
  // Capacities: the frames, the most kept entries of one frame, the largest kept cluster.
  int max_entries = 1, max_points = 1;
  for (const int f : frames) {
    int cameras = 0, clusters = 0;
    for (size_t i = first_camera[f]; i < first_camera[f + 1]; ++i) cameras += keep_camera[i];
    for (size_t j = first_lidar[f]; j < first_lidar[f + 1]; ++j) {
      if (!keep_lidar[j]) continue;
      ++clusters;
      max_points = std::max(max_points, s.lidar[j].num_points);
    }
    max_entries = std::max({max_entries, cameras, clusters});
  }

  SessionObservations out;
  out.Reserve(static_cast<int>(frames.size()), max_entries, max_points);
  out.lidar_valid_points = s.lidar_valid_points;  // the session's clouds, whichever frames
  out.lidar_outside_points = s.lidar_outside_points;
  std::vector<float> time_s;
  for (const int f : frames) {
    const FrameTimes& t = s.frame_times[static_cast<size_t>(f)];
    [[maybe_unused]] bool ok = out.BeginFrame(t);
    // AddLidarCluster takes firing times after the sweep start; the store keeps them relative to
    // the camera time (point_dt = sweep start - camera time + firing time).
    const float sweep_dt =
        static_cast<float>(static_cast<double>(t.lidar_utime - t.camera_utime) * 1e-6);
    for (size_t i = first_camera[f]; i < first_camera[f + 1]; ++i)
      if (keep_camera[i]) ok = out.AddCameraBoard(s.camera[i]) && ok;
    for (size_t j = first_lidar[f]; j < first_lidar[f + 1]; ++j) {
      if (!keep_lidar[j]) continue;
      const auto& c = s.lidar[j];
      const auto first = static_cast<size_t>(c.first_point);
      time_s.resize(static_cast<size_t>(c.num_points));
      for (size_t p = 0; p < time_s.size(); ++p) time_s[p] = s.point_dt[first + p] - sweep_dt;
      ok = out.AddLidarCluster(s.points.data() + first, time_s.data(), c.num_points) && ok;
      if (source_lidar) source_lidar->push_back(static_cast<int>(j));
    }
    assert(ok && "capacities are sized to fit");
  }
  return out;
}

SessionObservations Subset(const SessionObservations& s, const std::vector<char>& keep_frame,
                           const std::vector<char>& keep_camera,
                           const std::vector<char>& keep_lidar) {
  std::vector<int> frames;
  for (int f = 0; f < s.num_frames; ++f)
    if (keep_frame[static_cast<size_t>(f)]) frames.push_back(f);
  return SelectFrames(s, frames, keep_camera, keep_lidar);
}

}  // namespace calibd
