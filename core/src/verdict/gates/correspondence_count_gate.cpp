#include "calibd/core/verdict/gates/correspondence_count_gate.hpp"

namespace calibd {

Reason TooFewCorrespondences(const QualityFigures& q, const CorrespondenceCountConfig& c,
                             const std::string& after, std::string* detail) {
  if (q.frames_used < c.min_frames) {
    *detail = std::to_string(q.frames_used) + " frame pairs with a correspondence" + after + ", " +
              std::to_string(c.min_frames) + " needed";
    return Reason::kTooFewFrames;
  }
  if (q.boards_used < c.min_boards) {
    *detail = std::to_string(q.boards_used) + " board correspondences" + after + ", " +
              std::to_string(c.min_boards) + " needed";
    return Reason::kTooFewBoards;
  }
  return Reason::kNone;
}

}  // namespace calibd
