// The one table of reason codes (core reason.hpp): codes and names unique, every lookup a round
// trip (tests/doc_check.py checks that the operator guide's troubleshooting table lists each one
// with its code).

#include <gtest/gtest.h>

#include <set>
#include <sstream>

#include "calibd/core/verdict/reason.hpp"

namespace calibd {
namespace {

TEST(ReasonTest, CodesAndNamesAreUniqueAndRoundTrip) {
  std::set<int> codes;
  std::set<std::string_view> names;
  for (const ReasonName& r : kReasonNames) {
    EXPECT_TRUE(codes.insert(static_cast<int>(r.reason)).second) << r.name;
    EXPECT_TRUE(names.insert(r.name).second) << r.name;
    EXPECT_EQ(NameOf(r.reason), r.name);
    EXPECT_EQ(ReasonFromName(r.name), r.reason);
    EXPECT_EQ(ReasonFromCode(static_cast<uint8_t>(r.reason)), r.reason);
  }
  EXPECT_EQ(NameOf(Reason::kNone), "");
  EXPECT_EQ(ReasonFromName(""), Reason::kNone);
  EXPECT_EQ(ReasonFromName("a reason nobody coded"), Reason::kOther);
  EXPECT_EQ(ReasonFromCode(0x00), Reason::kNone);
  EXPECT_EQ(ReasonFromCode(0x7F), Reason::kOther);
  std::ostringstream os;
  os << Reason::kBoardNotFlat << " " << Reason::kNone;
  EXPECT_EQ(os.str(), "board_not_flat none");
}

}  // namespace
}  // namespace calibd
