#include "calibd/core/verdict/gates/board_flatness_gate.hpp"

#include <cmath>

#include "calibd/core/common/text_format.hpp"

namespace calibd {

Reason CheckBoardFlatness(const GateInput& in, std::string* detail) {
  const QualityFigures& q = in.quality;
  if (!(std::fabs(q.board_bend_m) > kMaxBoardBendM &&
        std::fabs(q.board_bend_m) > kBoardBendSigmas * q.board_bend_sigma_m))
    return Reason::kNone;
  return Refuse(detail, Reason::kBoardNotFlat,
                "board " + std::to_string(q.board_bend_id) + "'s face bends " +
                    FixedDecimal(std::fabs(q.board_bend_m) * 1e3, 1) + " mm (+-" +
                    FixedDecimal(q.board_bend_sigma_m * 1e3, 1) + ") " +
                    (q.board_bend_m > 0.0 ? "towards" : "away from") +
                    " the sensors at its centre line, more than " +
                    FixedDecimal(kMaxBoardBendM * 1e3, 1) +
                    " mm: the LiDAR sees it off the plane of its tag; flatten or replace the "
                    "board (the operator guide asks for 2 mm under a straight edge)");
}

}  // namespace calibd
