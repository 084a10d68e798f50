// The session marker (agent/session_marker.hpp): what the agent writes when a session
// starts, reads at start-up and removes when the session ends; the calibration store beside it
// ignores it.

#include "calibd/agent/session_marker.hpp"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "calibd/drivers/calibration_store.hpp"
#include "temp_dir.hpp"

namespace calibd {
namespace {

namespace fs = std::filesystem;

TEST(SessionMarkerTest, WrittenReadAndRemoved) {
  testing::TempDir dir;
  const std::string path = SessionMarkerPath(dir.path().string());
  SessionMarker m, read;
  std::string error;
  EXPECT_EQ(ReadSessionMarker(path, &read, &error), MarkerRead::kNone);
  m.session = 3;
  m.trigger = "uds calibrate";
  m.started_unix_s = 1795436018;
  ASSERT_TRUE(WriteSessionMarker(path, m, &error)) << error;
  ASSERT_EQ(ReadSessionMarker(path, &read, &error), MarkerRead::kFound) << error;
  EXPECT_EQ(read.session, 3);
  EXPECT_EQ(read.trigger, "uds calibrate");
  EXPECT_EQ(read.started_unix_s, 1795436018);
  // A write cut short by a kill leaves its temp file: removed with the marker.
  std::ofstream(path + ".tmp.12345") << "calibd-sess";
  ASSERT_TRUE(RemoveSessionMarker(path, &error)) << error;
  EXPECT_FALSE(fs::exists(path));
  EXPECT_FALSE(fs::exists(path + ".tmp.12345"));
  EXPECT_TRUE(RemoveSessionMarker(path, &error)) << "no marker: nothing to do";
}

TEST(SessionMarkerTest, ARequesterCannotAddLines) {
  testing::TempDir dir;
  const std::string path = SessionMarkerPath(dir.path().string());
  SessionMarker m, read;
  m.session = 1;
  m.trigger = "eol\nsession 9";
  std::string error;
  ASSERT_TRUE(WriteSessionMarker(path, m, &error)) << error;
  ASSERT_EQ(ReadSessionMarker(path, &read, &error), MarkerRead::kFound) << error;
  EXPECT_EQ(read.session, 1);
  EXPECT_EQ(read.trigger, "eol_session 9");
}

TEST(SessionMarkerTest, DamagedMarkerIsReportedUnreadable) {
  testing::TempDir dir;
  const std::string path = SessionMarkerPath(dir.path().string());
  SessionMarker read;
  std::string error;
  for (const char* text : {"", "calibd-session 1\nsession 0\ntrigger x\nstarted_unix_s 5\nend\n",
                           "calibd-session 1\nsession 2\ntrigger x\nstarted_unix_s 5\n",
                           "calibd-session 1\nsession two\ntrigger x\nstarted_unix_s 5\nend\n"}) {
    std::ofstream(path, std::ios::trunc) << text;
    error.clear();
    EXPECT_EQ(ReadSessionMarker(path, &read, &error), MarkerRead::kUnreadable) << text;
    EXPECT_NE(error.find("damaged session marker"), std::string::npos) << error;
  }
}

TEST(SessionMarkerTest, TheCalibrationStoreIgnoresIt) {
  testing::TempDir dir;
  CalibrationStoreConfig config;
  config.directory = dir.path().string();
  StoredCalibration c;
  c.created_unix_s = 1795436018;
  c.T_camera_lidar = Pose::Identity();
  c.lidar_serial = "L";
  c.camera_serial = "C";
  c.source = "test";
  c.verdict = "end_of_line";
  std::string error;
  {
    CalibrationStore store;
    ASSERT_TRUE(store.Open(config, &error)) << error;
    ASSERT_TRUE(store.Commit(c, &error)) << error;
  }
  SessionMarker m;
  m.session = 1;
  m.trigger = "start_button";
  ASSERT_TRUE(WriteSessionMarker(SessionMarkerPath(config.directory), m, &error)) << error;
  CalibrationStore store;
  ASSERT_TRUE(store.Open(config, &error)) << error;
  EXPECT_TRUE(store.load_warnings().empty());
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 1);
  ASSERT_TRUE(store.Commit(c, &error)) << error;  // a commit (and its trim) leaves it alone
  EXPECT_TRUE(fs::exists(SessionMarkerPath(config.directory)));
}

// The agent's marker across two runs: the first run's session left its marker (a kill), the
// second run finds it once, with who started it and when, and removes it; its own session's
// marker is gone when that session ends, and End without a Begin has nothing to remove.
TEST(SessionMarkerFileTest, APreviousRunsMarkerIsTakenOnceAndASessionsIsRemovedAtItsEnd) {
  testing::TempDir dir;
  std::string error;
  {
    SessionMarkerFile killed;
    killed.Open(dir.path().string());
    EXPECT_EQ(killed.TakeInterrupted(&error), "") << "no marker yet";
    SessionMarker m;
    m.session = 2;
    m.trigger = "start_button";
    m.started_unix_s = 1795436018;  // 2026-11-23T12:13:38Z
    ASSERT_TRUE(killed.Begin(m, &error)) << error;
  }  // no End: the run was killed
  SessionMarkerFile next;
  next.Open(dir.path().string());
  EXPECT_EQ(next.TakeInterrupted(&error),
            "the previous run stopped during session 2 (started by 'start_button' at "
            "2026-11-23T12:13:38Z) without a result: aborted; the stored calibration is unchanged");
  EXPECT_EQ(error, "");
  EXPECT_EQ(next.TakeInterrupted(&error), "") << "taken once";
  const std::string path = SessionMarkerPath(dir.path().string());
  EXPECT_TRUE(next.End(&error)) << "nothing written: nothing to remove";
  SessionMarker m;
  m.session = 1;
  m.trigger = "uds calibrate";
  ASSERT_TRUE(next.Begin(m, &error)) << error;
  EXPECT_TRUE(fs::exists(path));
  EXPECT_TRUE(next.End(&error)) << error;
  EXPECT_FALSE(fs::exists(path));
}

// A marker cut short still tells of an interrupted run, with what was wrong with it.
TEST(SessionMarkerFileTest, ADamagedMarkerStillTellsOfTheInterruptedRun) {
  testing::TempDir dir;
  const std::string path = SessionMarkerPath(dir.path().string());
  std::ofstream(path) << "calibd-session 1\nsess";
  SessionMarkerFile marker;
  marker.Open(dir.path().string());
  std::string error;
  const std::string line = marker.TakeInterrupted(&error);
  EXPECT_EQ(line.rfind("the previous run stopped during a session (", 0), 0u) << line;
  EXPECT_NE(line.find("without a result"), std::string::npos) << line;
  EXPECT_FALSE(fs::exists(path));
}

}  // namespace
}  // namespace calibd
