// calibd-bench verdicts on a few of its sessions: a clean one is accepted within tolerance and
// counted so, with its error inside the bound it predicts for itself, the same seed gives the
// same answer, and a fault drawn from the catalogue reaches the engine (a wrong tag size is
// refused for its scale, a wrong principal point for what the tags say); sessions derived from
// one recording answer as if recorded alone; a principal point a drive's tags cannot refute is
// caught by the bound, and one that still poses cannot check is not taken on the statement
// alone; and clean sessions of a held-out seed lie inside their bounds.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <sstream>

#include "calibd/core/verdict/principal_point_check.hpp"
#include "seed_kind.hpp"
#include "temp_dir.hpp"
#include "verdicts_bench.hpp"

namespace calibd::bench {
namespace {

// Runs quick sessions `only` of `seed`; `table` gets the bench's table (after its error, if it
// failed), `ok` whether it passed (no false accept); returns its JSON.
nlohmann::json RunSessions(const std::vector<int>& only, const std::string& json,
                           std::string* table, bool* ok, bool share_recordings = true,
                           unsigned long long seed = VerdictsBenchOptions{}.seed) {
  VerdictsBenchOptions o;
  o.quick = true;
  o.seed = seed;
  o.only = only;
  o.share_recordings = share_recordings;
  o.json_path = json;
  std::ostringstream out;
  std::string error;
  *ok = RunVerdictsBench(o, out, nullptr, &error);
  *table = error.empty() ? out.str() : error + "\n" + out.str();
  std::ifstream in(json);
  return nlohmann::json::parse(in);
}

// `--faults` keeps the sessions of the faults named, of the range or of `--only`, in order.
TEST(VerdictsBenchTest, FaultsPickTheirSessionsOfTheRangeOrOfTheList) {
  EXPECT_TRUE(IsVerdictFault("none"));
  EXPECT_TRUE(IsVerdictFault("boards_far"));
  EXPECT_FALSE(IsVerdictFault("clean"));
  VerdictsBenchOptions o;
  o.sessions = 3 * VerdictSessionIndex("none", 1);  // three rounds
  o.faults = {"none", "range_bias"};
  EXPECT_EQ(
      VerdictSessionIndices(o),
      (std::vector<int>{VerdictSessionIndex("none", 0), VerdictSessionIndex("range_bias", 0),
                        VerdictSessionIndex("none", 1), VerdictSessionIndex("range_bias", 1),
                        VerdictSessionIndex("none", 2), VerdictSessionIndex("range_bias", 2)}));
  o.only = {VerdictSessionIndex("range_bias", 4), VerdictSessionIndex("occluded", 4),
            VerdictSessionIndex("none", 7)};
  EXPECT_EQ(VerdictSessionIndices(o), (std::vector<int>{VerdictSessionIndex("range_bias", 4),
                                                        VerdictSessionIndex("none", 7)}));
  o.faults.clear();
  EXPECT_EQ(VerdictSessionIndices(o), o.only);
}

TEST(VerdictsBenchTest, ACleanSessionIsAcceptedAndSizeAndCentreFaultsAreRefusedForThem) {
  testing::TempDir dir;
  std::string table;
  bool ok = false;
  // Clean falcon still poses (round 5), an ot128 drive with a wrong tag size (round 0), m1 still
  // poses with a wrong principal point (round 3).
  const std::vector<int> sessions = {VerdictSessionIndex("none", 5),
                                     VerdictSessionIndex("tag_size", 0),
                                     VerdictSessionIndex("principal_point", 3)};
  const nlohmann::json first = RunSessions(sessions, dir.file("a.json"), &table, &ok);
  EXPECT_TRUE(ok) << table;
  // Seed 1 (the default) is a tuning seed, and the table and JSON say so.
  EXPECT_EQ(first["seed_kind"], "tuning");
  EXPECT_NE(table.find("(quick, seed 1, tuning)"), std::string::npos) << table;
  ASSERT_EQ(first["sessions"].size(), 3u);
  const nlohmann::json& clean = first["sessions"][0];
  EXPECT_EQ(clean["fault"], "none");
  EXPECT_EQ(clean["verdict"], "updated") << clean["detail"];
  EXPECT_LT(clean["rotation_error_deg"].get<double>(), 0.3);
  EXPECT_FALSE(clean["false_accept"].get<bool>());
  // Its true error lies inside the bound it predicts for itself, and that bound is finite.
  EXPECT_TRUE(clean["inside_bound"].get<bool>()) << clean["quality"].dump();
  EXPECT_TRUE(clean["quality"]["rotation_bound_deg"].is_number());
  EXPECT_GT(clean["quality"]["rotation_bound_deg"].get<double>(),
            clean["rotation_error_deg"].get<double>());
  const nlohmann::json& tag = first["sessions"][1];
  EXPECT_EQ(tag["fault"], "tag_size");
  EXPECT_EQ(tag["reason"], "camera_scale_mismatch") << tag["detail"];
  EXPECT_GT(std::fabs(tag["quality"]["camera_scale_error"].get<double>()), 0.01);
  EXPECT_NE(table.find("| none | clean session | 1 | 1 | 0 | 0 | 0 | 0 |"), std::string::npos)
      << table;
  EXPECT_NE(table.find("camera_scale_mismatch 1"), std::string::npos) << table;
  const nlohmann::json& centre = first["sessions"][2];
  EXPECT_EQ(centre["fault"], "principal_point");
  EXPECT_EQ(centre["reason"], "principal_point_mismatch") << centre["detail"];
  EXPECT_GT(centre["quality"]["principal_point_turn_deg"].get<double>(), 0.3);
  // Deterministic per seed.
  const nlohmann::json again = RunSessions({sessions[0]}, dir.file("b.json"), &table, &ok);
  EXPECT_EQ(again["sessions"][0]["rotation_error_deg"], clean["rotation_error_deg"]);
}

// A round's faults that change only the config, the stamps, the LiDAR's noise or the camera are
// derived from its clean recording (one simulation; detectors built alike copy each other): each
// answers as it does recorded alone, to the last bit, whichever sessions it is run with.
TEST(VerdictsBenchTest, SessionsSharingARecordingAnswerAsIfRecordedAlone) {
  testing::TempDir dir;
  std::string table;
  bool ok = false;
  // An OS1-64 drive (round 10), in the campaign's order: the clean session, a late camera (its
  // own images beside the shared sweeps), a wrong focal length (the clean LiDAR detector's output
  // copied), a range bias (its own sweep beside the shared images), a shuffled order (both
  // detectors' output copied).
  const int round = 10;
  const std::vector<int> together = {
      VerdictSessionIndex("none", round), VerdictSessionIndex("camera_delay_stamped", round),
      VerdictSessionIndex("focal_length", round), VerdictSessionIndex("range_bias", round),
      VerdictSessionIndex("frames_reordered", round)};
  const nlohmann::json shared = RunSessions(together, dir.file("shared.json"), &table, &ok);
  ASSERT_EQ(shared["sessions"].size(), together.size()) << table;
  const std::vector<int> faulty(together.begin() + 1, together.end());
  const nlohmann::json alone = RunSessions(faulty, dir.file("alone.json"), &table, &ok, false);
  ASSERT_EQ(alone["sessions"].size(), faulty.size()) << table;
  for (size_t k = 1; k < together.size(); ++k) {
    const nlohmann::json& a = alone["sessions"][k - 1];
    const nlohmann::json& s = shared["sessions"][k];
    SCOPED_TRACE(a["fault"].get<std::string>());
    EXPECT_EQ(s["fault"], a["fault"]);
    EXPECT_EQ(s["verdict"], a["verdict"]);
    EXPECT_EQ(s["reason"], a["reason"]);
    EXPECT_EQ(s["frames"], a["frames"]);
    EXPECT_EQ(s["camera_boards"], a["camera_boards"]);
    ASSERT_TRUE(a.contains("rotation_error_deg")) << a.dump();
    EXPECT_EQ(s["rotation_error_deg"], a["rotation_error_deg"]);
    EXPECT_EQ(s["translation_error_m"], a["translation_error_m"]);
    EXPECT_EQ(s["quality"]["rotation_bound_deg"], a["quality"]["rotation_bound_deg"]);
  }
  // The clean recording and a shuffled order of the same pairs solve to the same answer; the
  // faults change it.
  const nlohmann::json& clean = shared["sessions"][0];
  EXPECT_EQ(shared["sessions"][4]["rotation_error_deg"], clean["rotation_error_deg"]);
  for (size_t k : {1, 2, 3})
    EXPECT_NE(shared["sessions"][k]["rotation_error_deg"], clean["rotation_error_deg"]) << k;
}

// Runs `seed`'s principal point session of `round` and checks it is the `mode` session it is
// meant to be, its result more than 0.3 deg off, refused for poor observability naming the
// principal point, its error inside its bound; returns it.
nlohmann::json ExpectPrincipalPointRefused(int round, unsigned long long seed,
                                           const std::string& mode) {
  testing::TempDir dir;
  std::string table;
  bool ok = false;
  const nlohmann::json session =
      RunSessions({VerdictSessionIndex("principal_point", round)}, dir.file("pp.json"), &table, &ok,
                  true, seed)["sessions"][0];
  EXPECT_TRUE(ok) << table;
  EXPECT_EQ(session["fault"], "principal_point");
  EXPECT_EQ(session["mode"], mode);
  EXPECT_GT(session["rotation_error_deg"].get<double>(), 0.3) << session.dump();
  EXPECT_EQ(session["reason"], "poor_observability") << session["detail"];
  EXPECT_NE(session["detail"].get<std::string>().find("most of it the camera's principal point"),
            std::string::npos)
      << session["detail"];
  EXPECT_TRUE(session["inside_bound"].get<bool>()) << session["quality"].dump();
  return session;
}

// A principal point the tags of a drive cannot tell from the stated 1 px (seed 15, an ot128 drive,
// the config's principal point 6.5 px off: the tags read (2.2, 4.7) +-(1.9, 1.7) px beside a
// blind spot of 7 px) turns the result 0.31 deg, beyond the accuracy it must be known to. Read
// with their corners unbiased, the tags pull the bound over that: refused for the principal
// point, not accepted, its error inside its bound.
TEST(VerdictsBenchTest, APrincipalPointTheDrivesTagsCannotRefuteIsNotAcceptedBeyondItsBound) {
  const nlohmann::json session = ExpectPrincipalPointRefused(0, 15, "drive");
  EXPECT_EQ(session["quality"]["principal_point_bound_corners"], "unbiased");
}

// Still poses whose tags hardly see the principal point (seed 22, round 59, OS1-64: they measure
// it to +-4 / +-10 px), the config's 12.8 px off: nothing in the session could refute the stated
// 1 px, and a bound resting on it accepted the result 0.42 deg off in a 2000-session run. The
// statement now counts no sharper than the tags could check (kMaxStatedSharpening): refused, the
// principal point named, the error inside the bound.
TEST(VerdictsBenchTest, APrincipalPointNoPoseCanCheckIsNotTakenOnTheStatementAlone) {
  const nlohmann::json q = ExpectPrincipalPointRefused(59, 22, "stills")["quality"];
  EXPECT_GT(q["principal_point_sigma_px"][1].get<double>(),
            kMaxStatedSharpening * q["principal_point_stated_sigma_px"].get<double>());
}

// Tuning seed 3's falcon drive whose config puts the tag 39.9 mm off the board's centre: every
// board faces the camera alike, so the solve took the offset into the translation whole (3.7 cm
// off) and no check saw it. The camera sees the boards' edges where the tag says they are not;
// the bound takes that in, and the refusal names it.
TEST(VerdictsBenchTest, ATagOffItsBoardsCentreIsSeenByTheCameraAndBoundsTheTranslation) {
  testing::TempDir dir;
  std::string table;
  bool ok = false;
  const nlohmann::json session =
      RunSessions({VerdictSessionIndex("tag_off_centre", 4)}, dir.file("tag.json"), &table, &ok,
                  true, 3)["sessions"][0];
  EXPECT_TRUE(ok) << table;
  ASSERT_EQ(session["fault"], "tag_off_centre");
  EXPECT_EQ(session["mode"], "drive");
  EXPECT_GT(session["translation_error_m"].get<double>(), 0.03) << session.dump();
  EXPECT_EQ(session["reason"], "poor_observability") << session["detail"];
  EXPECT_NE(session["detail"].get<std::string>().find("where the boards' centres lie"),
            std::string::npos)
      << session["detail"];
  // The offset as the camera reads it, against the 39.9 mm configured (within 3 mm).
  const nlohmann::json& centre = session["quality"]["board_centre_offset_m"];
  ASSERT_TRUE(centre.is_array()) << session["quality"].dump();
  EXPECT_NEAR(std::hypot(centre[0].get<double>(), centre[1].get<double>()), 0.0399, 0.003);
  EXPECT_TRUE(session["inside_bound"].get<bool>()) << session["quality"].dump();
}

// The bound on sessions nobody tuned on: clean sessions of a seed no one looks at but this test
// (kHeldOutTestSeed), drives and still poses of ring, MEMS and non-repetitive LiDARs. Each solved
// session's true error lies inside the 99 % bound it predicts for itself, and none is accepted
// beyond the accuracy a result must be known to (RunVerdictsBench fails on a false accept).
TEST(VerdictsBenchTest, HeldOutCleanSessionsLieInsideTheirBounds) {
  testing::TempDir dir;
  // Rounds: ot128 drive, m1 stills, falcon drive, vlp32c stills, os1-64 drive, avia stills.
  std::vector<int> only;
  for (int round : {0, 3, 4, 9, 10, 13}) only.push_back(VerdictSessionIndex("none", round));
  std::string table;
  bool ok = false;
  const nlohmann::json doc =
      RunSessions(only, dir.file("held_out.json"), &table, &ok, true, kHeldOutTestSeed);
  EXPECT_TRUE(ok) << table;
  EXPECT_NE(table.find(", held-out)"), std::string::npos) << table;
  int solved = 0;
  for (const nlohmann::json& session : doc["sessions"]) {
    EXPECT_FALSE(session["false_accept"].get<bool>()) << session.dump();
    if (!session.contains("inside_bound")) continue;  // short of the agent's minimum
    ++solved;
    EXPECT_TRUE(session["inside_bound"].get<bool>()) << session.dump();
  }
  EXPECT_GE(solved, 4) << table;
  std::printf("%s", table.c_str());
}

}  // namespace
}  // namespace calibd::bench
