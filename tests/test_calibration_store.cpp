#include "calibd/drivers/calibration_store.hpp"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <functional>
#include <iterator>
#include <map>
#include <nlohmann/json.hpp>
#include <random>
#include <thread>

#include "temp_dir.hpp"
#include "tmpfs_mount.hpp"

namespace calibd {
namespace {

namespace fs = std::filesystem;

// A calibration whose every field depends on `i`, so a mix-up between versions shows.
StoredCalibration Example(int i) {
  StoredCalibration c;
  c.created_unix_s = 1700000000 + 3600 * i;
  c.T_camera_lidar =
      PoseFromXyzRpy({0.1 + 0.001 * i, -0.2, 0.3 - 0.0005 * i}, {-1.6 + 0.002 * i, 0.02, -1.55});
  c.lidar_serial = "LDR-0042";
  c.camera_serial = "CAM-0017";
  c.source = "on_vehicle";
  c.verdict = "updated";
  c.reprojection_mean_px = 1.0 / 3.0 + i;
  c.residual_rms_m = 0.0123 + 1e-4 * i;
  c.rotation_sigma_deg = 0.021 + 1e-3 * i;
  c.translation_sigma_m = 0.0034;
  c.rotation_bound_deg = 0.08 + 1e-3 * i;
  c.translation_bound_m = 0.011;
  c.frames_used = 40 + i;
  c.boards_used = 120 + 3 * i;
  return c;
}

StoredCalibration EndOfLine() {
  StoredCalibration c = Example(0);
  c.T_camera_lidar = PoseFromXyzRpy({0.1, -0.2, 0.3}, {-1.6, 0.0, -1.55});
  c.source = "end_of_line";
  c.verdict = "end_of_line";
  c.verified_unix_s = 1690000000;
  return c;
}

CalibrationStoreConfig Config(const testing::TempDir& dir, int keep_previous = 5) {
  CalibrationStoreConfig config;
  config.directory = dir.file("store");
  config.keep_previous = keep_previous;
  return config;
}

// The fields a caller supplies (not version, replaced_version, deltas), compared exactly: the
// file format must give back the same doubles.
void ExpectSameInput(const StoredCalibration& a, const StoredCalibration& b) {
  EXPECT_EQ(a.created_unix_s, b.created_unix_s);
  EXPECT_EQ(a.verified_unix_s, b.verified_unix_s);
  EXPECT_TRUE(a.T_camera_lidar.matrix() == b.T_camera_lidar.matrix())
      << a.T_camera_lidar.matrix() << "\nvs\n"
      << b.T_camera_lidar.matrix();
  EXPECT_EQ(a.lidar_serial, b.lidar_serial);
  EXPECT_EQ(a.camera_serial, b.camera_serial);
  EXPECT_EQ(a.source, b.source);
  EXPECT_EQ(a.verdict, b.verdict);
  EXPECT_EQ(a.reprojection_mean_px, b.reprojection_mean_px);
  EXPECT_EQ(a.residual_rms_m, b.residual_rms_m);
  EXPECT_EQ(a.rotation_sigma_deg, b.rotation_sigma_deg);
  EXPECT_EQ(a.translation_sigma_m, b.translation_sigma_m);
  EXPECT_EQ(a.rotation_bound_deg, b.rotation_bound_deg);
  EXPECT_EQ(a.translation_bound_m, b.translation_bound_m);
  EXPECT_EQ(a.frames_used, b.frames_used);
  EXPECT_EQ(a.boards_used, b.boards_used);
}

void ExpectSame(const StoredCalibration& a, const StoredCalibration& b) {
  ExpectSameInput(a, b);
  EXPECT_EQ(a.version, b.version);
  EXPECT_EQ(a.replaced_version, b.replaced_version);
  EXPECT_EQ(a.delta_rotation_deg, b.delta_rotation_deg);
  EXPECT_EQ(a.delta_translation_m, b.delta_translation_m);
}

// Current, reference and history of two stores are identical.
void ExpectSameState(const CalibrationStore& a, const CalibrationStore& b) {
  ASSERT_EQ(a.current() == nullptr, b.current() == nullptr);
  if (a.current()) ExpectSame(*a.current(), *b.current());
  ASSERT_EQ(a.reference() == nullptr, b.reference() == nullptr);
  if (a.reference()) ExpectSame(*a.reference(), *b.reference());
  ASSERT_EQ(a.history().size(), b.history().size());
  for (size_t i = 0; i < a.history().size(); ++i) ExpectSame(a.history()[i], b.history()[i]);
}

std::vector<int64_t> Versions(const std::vector<StoredCalibration>& history) {
  std::vector<int64_t> v;
  for (const auto& c : history) v.push_back(c.version);
  return v;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << bytes;
}

// Overwrites one byte in place. Unlike WriteBytes it does not truncate the file first, which on
// ext4 (auto_da_alloc) forces a flush at close and made the byte-by-byte loop below slow.
void PutByte(const std::string& path, size_t offset, char byte) {
  std::fstream f(path, std::ios::binary | std::ios::in | std::ios::out);
  f.seekp(static_cast<std::streamoff>(offset));
  f.put(byte);
}

// Every regular file under `root` (relative name -> contents): "the files are untouched".
std::map<std::string, std::string> Snapshot(const std::string& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.is_regular_file())
      files[fs::relative(e.path(), root).string()] = ReadBytes(e.path().string());
  return files;
}

// Temp files ("<target>.tmp.<pid>", atomic_file.cpp) in the store and its history.
int TempFilesIn(const std::string& root) {
  int n = 0;
  for (const auto& e : fs::recursive_directory_iterator(root))
    if (e.path().filename().string().find(".tmp.") != std::string::npos) ++n;
  return n;
}

bool AnyWarningHas(const CalibrationStore& store, const std::string& a, const std::string& b) {
  for (const auto& w : store.load_warnings())
    if (w.find(a) != std::string::npos && w.find(b) != std::string::npos) return true;
  return false;
}

std::string JoinWarnings(const CalibrationStore& store) {
  std::string all;
  for (const auto& w : store.load_warnings()) all += w + "\n";
  return all;
}

// Opens `config` in a fresh store and commits Example(1..n).
void CommitExamples(const CalibrationStoreConfig& config, int n) {
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(config, &error)) << error;
  for (int i = 1; i <= n; ++i) ASSERT_TRUE(store.Commit(Example(i), &error)) << error;
}

// fuzz_calibration_store found a number beyond double's range ("666666666E6666666666666") making
// nlohmann::json throw out_of_range, which escaped the parser: the agent would have died at start
// on such a file. Now it is a corrupt file like any other.
TEST(CalibrationStoreTest, NumberOverflowIsACorruptFileNotACrash) {
  std::ifstream in(
      std::string(CALIBD_SOURCE_DIR) + "/tests/fuzz/corpus/calibration_store/crash-number-overflow",
      std::ios::binary);
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  ASSERT_EQ(text.size(), 95u);
  StoredCalibration c;
  std::string error;
  EXPECT_FALSE(ParseCalibrationFile(text, &c, &error));
  EXPECT_NE(error.find("not valid JSON"), std::string::npos) << error;
  EXPECT_FALSE(ParseCalibrationFile("{\"format\": 1e999}", &c, &error));
  EXPECT_NE(error.find("not valid JSON"), std::string::npos) << error;
}

TEST(CalibrationStoreTest, NewStoreIsEmptyAndCreatesItsDirectory) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  EXPECT_EQ(store.current(), nullptr);
  EXPECT_EQ(store.reference(), nullptr);
  EXPECT_TRUE(store.history().empty());
  EXPECT_TRUE(store.load_warnings().empty()) << JoinWarnings(store);
  struct stat st {};
  ASSERT_EQ(::stat(dir.file("store").c_str(), &st), 0);
  EXPECT_TRUE(S_ISDIR(st.st_mode));
  EXPECT_EQ(st.st_mode & 0777, 0700u);
  EXPECT_TRUE(fs::is_directory(dir.file("store/history")));
}

TEST(CalibrationStoreTest, RoundTripsEveryFieldThroughTheFiles) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;
  StoredCalibration c = Example(3);
  c.verified_unix_s = 1700001234;
  c.T_camera_lidar = PoseFromXyzRpy({1.0 / 7.0, -2e-17, 123.456789}, {-1.6, 1e-9, M_PI / 3.0});
  c.reprojection_mean_px = 0.1 + 0.2;  // not the double nearest 0.3: must survive exactly
  c.translation_sigma_m = 5e-324;      // denormal
  ASSERT_TRUE(store.Commit(c, &error)) << error;

  ASSERT_NE(store.current(), nullptr);
  const StoredCalibration& current = *store.current();
  ExpectSameInput(current, c);
  EXPECT_EQ(current.version, 2);  // the reference took version 1
  EXPECT_EQ(current.replaced_version, 0);
  EXPECT_EQ(current.delta_rotation_deg, 0.0);
  EXPECT_EQ(store.reference()->version, 1);

  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
  EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
  ExpectSameState(store, reopened);
  ExpectSameInput(*reopened.reference(), EndOfLine());
}

TEST(CalibrationStoreTest, VerifiedUpdatedRejectedSequence) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  // End of line: the reference, and the first current calibration.
  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;
  ASSERT_TRUE(store.Commit(EndOfLine(), &error)) << error;
  EXPECT_EQ(store.current()->version, 2);

  // Session 1, `verified`: the same version, now with the verification time.
  ASSERT_TRUE(store.MarkVerified(1700000100, &error)) << error;
  EXPECT_EQ(store.current()->version, 2);
  EXPECT_EQ(store.current()->verified_unix_s, 1700000100);
  EXPECT_TRUE(store.history().empty());

  // Session 2, `updated`: a new version; the verified one moves into the history.
  const StoredCalibration updated = Example(4);
  ASSERT_TRUE(store.Commit(updated, &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 3);
  EXPECT_EQ(store.current()->replaced_version, 2);
  ExpectSameInput(*store.current(), updated);
  EXPECT_NEAR(store.current()->delta_rotation_deg,
              RotationAngle(EndOfLine().T_camera_lidar.linear(), updated.T_camera_lidar.linear()) *
                  kRad2Deg,
              1e-12);
  EXPECT_NEAR(
      store.current()->delta_translation_m,
      (updated.T_camera_lidar.translation() - EndOfLine().T_camera_lidar.translation()).norm(),
      1e-15);
  ASSERT_EQ(Versions(store.history()), (std::vector<int64_t>{2}));
  EXPECT_EQ(store.history()[0].verified_unix_s, 1700000100);

  // Session 3, `rejected`: refused with the reason, nothing changes in memory or on disk.
  const auto files_before = Snapshot(dir.file("store"));
  StoredCalibration rejected = Example(5);
  rejected.verdict = "rejected";
  EXPECT_FALSE(store.Commit(rejected, &error));
  EXPECT_NE(error.find("verdict"), std::string::npos) << error;
  EXPECT_EQ(store.current()->version, 3);
  EXPECT_EQ(Versions(store.history()), (std::vector<int64_t>{2}));
  EXPECT_EQ(Snapshot(dir.file("store")), files_before);

  // Session 4, `verified` again.
  ASSERT_TRUE(store.MarkVerified(1700000400, &error)) << error;
  EXPECT_EQ(store.current()->version, 3);
  EXPECT_EQ(store.current()->verified_unix_s, 1700000400);

  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
  EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
  ExpectSameState(store, reopened);
  EXPECT_EQ(reopened.current()->verified_unix_s, 1700000400);
  EXPECT_EQ(reopened.history()[0].verified_unix_s, 1700000100);
}

TEST(CalibrationStoreTest, BadInputIsRefusedWithTheFieldNamed) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_TRUE(store.Commit(Example(1), &error)) << error;
  struct Case {
    std::function<void(StoredCalibration*)> spoil;
    std::string field;
  };
  const std::vector<Case> cases = {
      {[](StoredCalibration* c) { c->lidar_serial.clear(); }, "lidar_serial"},
      {[](StoredCalibration* c) { c->camera_serial = "CAM\n1"; }, "camera_serial"},
      {[](StoredCalibration* c) { c->source.clear(); }, "source"},
      {[](StoredCalibration* c) { c->T_camera_lidar.linear() *= 2.0; }, "T_camera_lidar"},
      {[](StoredCalibration* c) { c->T_camera_lidar.matrix()(0, 3) = NAN; }, "T_camera_lidar"},
      {[](StoredCalibration* c) { c->residual_rms_m = -1.0; }, "residual_rms_m"},
      {[](StoredCalibration* c) { c->reprojection_mean_px = INFINITY; }, "reprojection_mean_px"},
      {[](StoredCalibration* c) { c->frames_used = -1; }, "frames_used"},
      {[](StoredCalibration* c) { c->created_unix_s = -5; }, "created_unix_s"},
  };
  const auto files_before = Snapshot(dir.file("store"));
  for (const auto& bad : cases) {
    StoredCalibration c = Example(2);
    bad.spoil(&c);
    error.clear();
    EXPECT_FALSE(store.Commit(c, &error)) << bad.field;
    EXPECT_NE(error.find(bad.field), std::string::npos) << error;
    EXPECT_FALSE(store.SetReference(c, &error)) << bad.field;
  }
  EXPECT_EQ(store.current()->version, 1);
  EXPECT_EQ(store.reference(), nullptr);
  EXPECT_EQ(Snapshot(dir.file("store")), files_before);
}

TEST(CalibrationStoreTest, ConfigAndDirectoryErrorsNameTheProblem) {
  testing::TempDir dir;
  std::string error;
  CalibrationStoreConfig config = Config(dir);
  config.keep_previous = -1;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("keep_previous"), std::string::npos) << error;
  CalibrationStore store;
  EXPECT_FALSE(store.Open(config, &error));

  config = Config(dir);
  WriteBytes(config.directory, "not a directory");
  EXPECT_FALSE(store.Open(config, &error));
  EXPECT_NE(error.find(config.directory), std::string::npos) << error;
  EXPECT_FALSE(store.Commit(Example(1), &error));  // a store that failed to open writes nothing
}

TEST(CalibrationStoreTest, HistoryIsTrimmedToKeepPrevious) {
  testing::TempDir dir;
  CommitExamples(Config(dir, 2), 6);
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir, 2), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 6);
  ExpectSameInput(*store.current(), Example(6));
  ASSERT_EQ(Versions(store.history()), (std::vector<int64_t>{5, 4}));
  ExpectSameInput(store.history()[0], Example(5));
  ExpectSameInput(store.history()[1], Example(4));
  // On disk: the current version's copy and the two kept previous ones, nothing else.
  std::vector<std::string> names;
  for (const auto& e : fs::directory_iterator(dir.file("store/history")))
    names.push_back(e.path().filename().string());
  std::sort(names.begin(), names.end());
  EXPECT_EQ(names, (std::vector<std::string>{"v000004.json", "v000005.json", "v000006.json"}));

  // keep_previous = 0: only the current calibration is kept.
  ASSERT_TRUE(store.Open(Config(dir, 0), &error)) << error;
  ASSERT_TRUE(store.Commit(Example(7), &error)) << error;
  EXPECT_TRUE(store.history().empty());
  EXPECT_EQ(Snapshot(dir.file("store/history")).size(), 1u);
}

TEST(CalibrationStoreTest, CorruptCurrentFileFallsBackToTheNewestValidVersion) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 3);
  const std::string current_path = dir.file("store/current.json");
  std::string bytes = ReadBytes(current_path);
  const auto serial = bytes.find("LDR-0042");
  ASSERT_NE(serial, std::string::npos);
  bytes[serial + 4] = static_cast<char>(bytes[serial + 4] ^ 0x01);  // "LDR-1042": still JSON
  WriteBytes(current_path, bytes);

  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 3);
  ExpectSameInput(*store.current(), Example(3));
  EXPECT_EQ(Versions(store.history()), (std::vector<int64_t>{2, 1}));
  ASSERT_EQ(store.load_warnings().size(), 1u) << JoinWarnings(store);
  EXPECT_EQ(store.load_warnings()[0],
            "current.json: checksum mismatch (file corrupt or truncated), using version 3 from "
            "history/v000003.json");

  // The newest history copy is bad too: version 2 becomes current, and the next commit still
  // gets version 4 (a version number is never reused).
  WriteBytes(dir.file("store/history/v000003.json"),
             ReadBytes(dir.file("store/history/v000003.json")).substr(0, 200));
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
  ExpectSameInput(*store.current(), Example(2));
  EXPECT_EQ(Versions(store.history()), (std::vector<int64_t>{1}));
  EXPECT_TRUE(AnyWarningHas(store, "history/v000003.json", "not valid JSON"))
      << JoinWarnings(store);
  EXPECT_TRUE(AnyWarningHas(store, "current.json", "using version 2 from history/v000002.json"))
      << JoinWarnings(store);
  ASSERT_TRUE(store.Commit(Example(4), &error)) << error;
  EXPECT_EQ(store.current()->version, 4);
  EXPECT_EQ(store.current()->replaced_version, 2);
}

TEST(CalibrationStoreTest, TruncatedCurrentFileFallsBackToHistory) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  const std::string current_path = dir.file("store/current.json");
  const std::string bytes = ReadBytes(current_path);
  WriteBytes(current_path, bytes.substr(0, bytes.size() / 2));

  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
  ExpectSameInput(*store.current(), Example(2));
  ASSERT_EQ(store.load_warnings().size(), 1u) << JoinWarnings(store);
  EXPECT_TRUE(AnyWarningHas(store, "current.json: not valid JSON", "(file corrupt or truncated)"))
      << JoinWarnings(store);
  EXPECT_TRUE(AnyWarningHas(store, "current.json", "using version 2 from history/v000002.json"));

  // An empty current.json (a crash on a filesystem without ordered writes) is the same case.
  WriteBytes(current_path, "");
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
}

// Property: whatever single byte of current.json is damaged, and wherever it is cut, the loaded
// calibration is the committed one, never a corrupted variant.
TEST(CalibrationStoreTest, NoSingleByteDamageOrTruncationIsEverLoaded) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  CalibrationStore clean;
  std::string error;
  ASSERT_TRUE(clean.Open(Config(dir), &error)) << error;
  const std::string current_path = dir.file("store/current.json");
  const std::string bytes = ReadBytes(current_path);
  int detected = 0;
  for (size_t i = 0; i < bytes.size(); ++i) {
    for (const char mask : {'\x01', '\x80'}) {
      PutByte(current_path, i, static_cast<char>(bytes[i] ^ mask));
      CalibrationStore store;
      ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
      ASSERT_NE(store.current(), nullptr) << "byte " << i;
      ExpectSame(*store.current(), *clean.current());
      if (!store.load_warnings().empty()) ++detected;
      PutByte(current_path, i, bytes[i]);
      if (::testing::Test::HasFailure()) FAIL() << "byte " << i << " mask " << int(mask);
    }
  }
  for (size_t n = bytes.size(); n-- > 0;) {  // shortening only: no truncate-to-zero flush
    ASSERT_EQ(::truncate(current_path.c_str(), static_cast<off_t>(n)), 0);
    CalibrationStore store;
    ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
    ASSERT_NE(store.current(), nullptr) << "cut at " << n;
    ExpectSame(*store.current(), *clean.current());
    if (::testing::Test::HasFailure()) FAIL() << "cut at " << n;
  }
  // Most flips are detected; the rest fall in whitespace or spell the same number (harmless).
  EXPECT_GT(detected, static_cast<int>(bytes.size()));
}

// The same property for the store's other files: whatever single byte of reference.json or of a
// history file is damaged, and wherever it is cut, that file is either loaded exactly as written
// or skipped with a warning naming it, and nothing else changes: the current calibration (also
// when the damaged file is its own history copy), the other history entries, the reference.
TEST(CalibrationStoreTest, NoSingleByteDamageOfReferenceOrHistoryIsEverLoaded) {
  testing::TempDir dir;
  {
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
    ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;  // version 1
    for (int i = 1; i <= 3; ++i) ASSERT_TRUE(store.Commit(Example(i), &error)) << error;
  }
  CalibrationStore clean;
  std::string error;
  ASSERT_TRUE(clean.Open(Config(dir), &error)) << error;
  ASSERT_EQ(clean.current()->version, 4);
  ASSERT_EQ(Versions(clean.history()), (std::vector<int64_t>{3, 2}));
  // reference.json; the oldest history file; the current version's own history copy.
  for (const char* name : {"reference.json", "history/v000002.json", "history/v000004.json"}) {
    SCOPED_TRACE(name);
    const std::string path = dir.file(std::string("store/") + name);
    const std::string bytes = ReadBytes(path);
    int skipped = 0;
    // The loaded state is the clean one, except that the damaged file may be missing from it.
    auto check = [&](const std::string& what) {
      CalibrationStore store;
      ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
      ASSERT_NE(store.current(), nullptr) << what;
      ExpectSame(*store.current(), *clean.current());
      const bool warned = AnyWarningHas(store, name, "");
      EXPECT_LE(store.load_warnings().size(), 1u) << what << "\n" << JoinWarnings(store);
      if (std::string(name) == "reference.json") {
        ASSERT_EQ(store.reference() == nullptr, warned) << what << "\n" << JoinWarnings(store);
        if (store.reference()) ExpectSame(*store.reference(), *clean.reference());
      } else {
        ASSERT_NE(store.reference(), nullptr) << what;
        ExpectSame(*store.reference(), *clean.reference());
      }
      std::vector<int64_t> expected_history = Versions(clean.history());
      if (std::string(name) == "history/v000002.json" && warned)
        expected_history.pop_back();  // skipped: v2 is gone from the history, nothing else
      ASSERT_EQ(Versions(store.history()), expected_history) << what << "\n" << JoinWarnings(store);
      for (size_t i = 0; i < store.history().size(); ++i)
        ExpectSame(store.history()[i], clean.history()[i]);
      if (warned) ++skipped;
    };
    // Every byte flipped (low and high bit in turn) and every 4th length: the parser is the one
    // current.json's exhaustive test above covers; here the choice of what to load is under
    // test, and the sanitizer pass stays within seconds.
    for (size_t i = 0; i < bytes.size(); ++i) {
      const char mask = i % 2 == 0 ? '\x01' : '\x80';
      PutByte(path, i, static_cast<char>(bytes[i] ^ mask));
      check("byte " + std::to_string(i) + " mask " + std::to_string(int(mask)));
      PutByte(path, i, bytes[i]);
      if (::testing::Test::HasFailure()) FAIL() << "byte " << i << " mask " << int(mask);
    }
    int cuts = 0;
    for (size_t cut = 1; cut <= bytes.size(); cut += 4) {  // shortening only, as above
      const size_t n = bytes.size() - cut;
      ASSERT_EQ(::truncate(path.c_str(), static_cast<off_t>(n)), 0);
      check("cut at " + std::to_string(n));
      ++cuts;
      if (::testing::Test::HasFailure()) FAIL() << "cut at " << n;
    }
    WriteBytes(path, bytes);
    // Most damage is detected (every cut is); the rest is harmless (whitespace, same number).
    EXPECT_GT(skipped, static_cast<int>(bytes.size() / 2) + cuts);
  }
}

TEST(CalibrationStoreTest, AllFilesCorruptMeansNoCurrentAndAWarningPerFile) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  for (const char* name : {"current.json", "history/v000001.json", "history/v000002.json"}) {
    const std::string path = dir.file(std::string("store/") + name);
    std::string bytes = ReadBytes(path);
    bytes[bytes.size() / 2] = static_cast<char>(bytes[bytes.size() / 2] ^ 0x04);
    WriteBytes(path, bytes);
  }
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  EXPECT_EQ(store.current(), nullptr);
  EXPECT_TRUE(store.history().empty());
  EXPECT_EQ(store.load_warnings().size(), 3u) << JoinWarnings(store);
  EXPECT_TRUE(AnyWarningHas(store, "history/v000001.json", "skipped"));
  EXPECT_TRUE(AnyWarningHas(store, "history/v000002.json", "skipped"));
  EXPECT_TRUE(AnyWarningHas(store, "current.json", "no current calibration"));
  EXPECT_FALSE(store.MarkVerified(1700000000, &error));
  EXPECT_NE(error.find("no current calibration"), std::string::npos) << error;
  // The store still works, with a version after every one seen.
  ASSERT_TRUE(store.Commit(Example(3), &error)) << error;
  EXPECT_EQ(store.current()->version, 3);
  EXPECT_EQ(store.current()->replaced_version, 0);
}

TEST(CalibrationStoreTest, FileFromAFutureFormatIsSkippedWithAClearWarning) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  const std::string path = dir.file("store/current.json");
  auto file = nlohmann::ordered_json::parse(ReadBytes(path));
  file["format_version"] = 3;
  WriteBytes(path, file.dump(2));
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
  EXPECT_TRUE(AnyWarningHas(store, "current.json: format version 3 is newer", "using version 2"))
      << JoinWarnings(store);
}

// A store written before the error bound (format 1, as calibd wrote it then, checksum and all)
// is read with the bound unknown (0), and a damaged one is still refused; a format-1 file with
// the bound's fields is not a file any calibd wrote.
TEST(CalibrationStoreTest, FilesOfFormatOneAreReadWithTheBoundUnknown) {
  const std::string v1 = R"({
  "format": "calibd.calibration",
  "format_version": 1,
  "calibration": {
    "version": 1,
    "replaced_version": 0,
    "created_unix_s": 1700000000,
    "verified_unix_s": 0,
    "T_camera_lidar": [
      [0.9950041652780258, -0.09983341664682815, 0.0, 0.05],
      [0.09983341664682815, 0.9950041652780258, 0.0, -0.48],
      [0.0, 0.0, 1.0, -0.42],
      [0.0, 0.0, 0.0, 1.0]
    ],
    "lidar_serial": "LIDAR-1",
    "camera_serial": "CAM-1",
    "source": "workshop",
    "verdict": "updated",
    "reprojection_mean_px": 0.42,
    "residual_rms_m": 0.0123,
    "rotation_sigma_deg": 0.015,
    "translation_sigma_m": 0.0021,
    "frames_used": 60,
    "boards_used": 165,
    "delta_rotation_deg": 0.0,
    "delta_translation_m": 0.0
  },
  "crc32": "02b579a7"
}
)";
  StoredCalibration c;
  std::string error;
  ASSERT_TRUE(ParseCalibrationFile(v1, &c, &error)) << error;
  EXPECT_EQ(c.boards_used, 165);
  EXPECT_EQ(c.rotation_sigma_deg, 0.015);
  EXPECT_EQ(c.rotation_bound_deg, 0.0);
  EXPECT_EQ(c.translation_bound_m, 0.0);
  std::string damaged = v1;
  damaged.replace(damaged.find("0.0123"), 6, "0.0124");
  EXPECT_FALSE(ParseCalibrationFile(damaged, &c, &error));
  EXPECT_NE(error.find("checksum mismatch"), std::string::npos) << error;
  std::string with_bound = v1;
  with_bound.replace(with_bound.find("\"delta_rotation_deg\""), 0,
                     "\"rotation_bound_deg\": 0.1,\n    ");
  EXPECT_FALSE(ParseCalibrationFile(with_bound, &c, &error));
  EXPECT_NE(error.find("rotation_bound_deg"), std::string::npos) << error;

  // Written again, it is of format 2 and keeps its figures.
  testing::TempDir dir;
  CalibrationStore store;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  WriteBytes(dir.file("store/current.json"), v1);
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr) << JoinWarnings(store);
  StoredCalibration next = Example(1);
  ASSERT_TRUE(store.Commit(next, &error)) << error;
  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
  EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
  ASSERT_NE(reopened.current(), nullptr);
  ExpectSameInput(*reopened.current(), next);
  EXPECT_NE(ReadBytes(dir.file("store/current.json")).find("\"format_version\": 2"),
            std::string::npos);
}

TEST(CalibrationStoreTest, CorruptReferenceIsReportedAndTheCurrentKept) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;
  ASSERT_TRUE(store.Commit(Example(1), &error)) << error;
  const std::string path = dir.file("store/reference.json");
  WriteBytes(path, ReadBytes(path).substr(0, 100));
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  EXPECT_EQ(store.reference(), nullptr);
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);
  EXPECT_TRUE(AnyWarningHas(store, "reference.json: not valid JSON", "no reference"))
      << JoinWarnings(store);
  EXPECT_FALSE(store.RestoreReference(1700000000, &error));
  EXPECT_NE(error.find("no reference"), std::string::npos) << error;
}

// A crash after history/v3 was written but before current.json was replaced (simulated by
// putting the old current.json back) loads version 3: the interrupted commit is completed.
TEST(CalibrationStoreTest, CommitInterruptedBeforeCurrentFileIsCompletedOnLoad) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  const std::string current_path = dir.file("store/current.json");
  const std::string old_current = ReadBytes(current_path);
  {
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
    ASSERT_TRUE(store.Commit(Example(3), &error)) << error;
  }
  WriteBytes(current_path, old_current);
  WriteBytes(current_path + ".tmp.99999", "{\"half\": ");  // the interrupted temp file
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 3);
  ExpectSameInput(*store.current(), Example(3));
  EXPECT_EQ(Versions(store.history()), (std::vector<int64_t>{2, 1}));
  EXPECT_TRUE(AnyWarningHas(store, "current.json: holds version 2", "interrupted"))
      << JoinWarnings(store);
  // The next commit repairs current.json and removes the temp file.
  ASSERT_TRUE(store.Commit(Example(4), &error)) << error;
  EXPECT_FALSE(fs::exists(current_path + ".tmp.99999"));
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  EXPECT_TRUE(store.load_warnings().empty()) << JoinWarnings(store);
  EXPECT_EQ(store.current()->version, 4);
}

// The current version's history copy is gone (deleted by hand, or its write failed): the next
// commit writes it back before replacing current.json, so the old current is not lost.
TEST(CalibrationStoreTest, CommitKeepsTheOldCurrentWhenItsHistoryCopyIsMissing) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  fs::remove(dir.file("store/history/v000002.json"));
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  ASSERT_NE(store.current(), nullptr);
  EXPECT_EQ(store.current()->version, 2);  // from current.json
  ASSERT_TRUE(store.Commit(Example(3), &error)) << error;

  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
  EXPECT_EQ(reopened.current()->version, 3);
  ASSERT_EQ(Versions(reopened.history()), (std::vector<int64_t>{2, 1}));
  ExpectSameInput(reopened.history()[0], Example(2));
}

// Makes WriteFileAtomic fail for `target` in this process: its temp path ("<target>.tmp.<pid>",
// atomic_file.cpp) is taken by a directory, so open(O_CREAT) fails with EISDIR. This works as
// root too, where permission bits would not stop a write.
void BlockWrites(const std::string& target) {
  fs::create_directory(target + ".tmp." + std::to_string(::getpid()));
}

void UnblockWrites(const std::string& target) {
  fs::remove(target + ".tmp." + std::to_string(::getpid()));
}

// Storage failing at each write of a commit (the new history file; current.json, after the
// history file was written): Commit reports the path, and memory and disk are as before.
TEST(CalibrationStoreTest, FailedCommitChangesNothing) {
  for (const char* blocked : {"history/v000003.json", "current.json"}) {
    SCOPED_TRACE(blocked);
    testing::TempDir dir;
    CommitExamples(Config(dir), 2);
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
    const CalibrationStore before = store;
    const auto files_before = Snapshot(dir.file("store"));
    BlockWrites(dir.file(std::string("store/") + blocked));

    EXPECT_FALSE(store.Commit(Example(3), &error));
    EXPECT_NE(error.find(dir.file(std::string("store/") + blocked)), std::string::npos) << error;
    ExpectSameState(store, before);
    EXPECT_EQ(Snapshot(dir.file("store")), files_before);

    UnblockWrites(dir.file(std::string("store/") + blocked));
    CalibrationStore reopened;
    ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
    EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
    ExpectSameState(reopened, before);
    // Once storage works again, the version the failed commit would have used is used.
    ASSERT_TRUE(store.Commit(Example(3), &error)) << error;
    EXPECT_EQ(store.current()->version, 3);
  }
}

TEST(CalibrationStoreTest, FailedMarkVerifiedChangesNothing) {
  for (const char* blocked : {"current.json", "history/v000002.json"}) {
    SCOPED_TRACE(blocked);
    testing::TempDir dir;
    CommitExamples(Config(dir), 2);
    CalibrationStore store;
    std::string error;
    ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
    const auto files_before = Snapshot(dir.file("store"));
    BlockWrites(dir.file(std::string("store/") + blocked));
    EXPECT_FALSE(store.MarkVerified(1700009999, &error));
    EXPECT_NE(error.find(dir.file(std::string("store/") + blocked)), std::string::npos) << error;
    EXPECT_EQ(store.current()->verified_unix_s, 0);
    EXPECT_EQ(Snapshot(dir.file("store")), files_before);
  }
}

// A genuinely read-only store directory: Commit must fail naming the path, with memory and files
// unchanged. Returns what went wrong ("" when nothing did); plain checks, as it may run in a child.
std::string ReadOnlyCommitFailure(const testing::TempDir& dir) {
  CalibrationStore store;
  std::string error;
  if (!store.Open(Config(dir), &error)) return "open: " + error;
  if (store.current() == nullptr) return "no current calibration after two commits";
  const int64_t version = store.current()->version;
  const size_t history = store.history().size();
  const auto files_before = Snapshot(dir.file("store"));
  fs::permissions(dir.file("store/history"), fs::perms::owner_read | fs::perms::owner_exec);
  fs::permissions(dir.file("store"), fs::perms::owner_read | fs::perms::owner_exec);
  std::string failure;
  if (store.Commit(Example(3), &error))
    failure = "Commit succeeded in a read-only directory";
  else if (error.find(dir.file("store/history")) == std::string::npos)
    failure = "the error does not name the directory: " + error;
  else if (store.current() == nullptr || store.current()->version != version ||
           store.history().size() != history)
    failure = "the in-memory state changed";
  fs::permissions(dir.file("store"), fs::perms::owner_all);
  fs::permissions(dir.file("store/history"), fs::perms::owner_all);
  if (failure.empty() && Snapshot(dir.file("store")) != files_before) failure = "the files changed";
  return failure;
}

TEST(CalibrationStoreTest, ReadOnlyDirectoryRefusesCommit) {
  testing::TempDir dir;
  CommitExamples(Config(dir), 2);
  if (::geteuid() != 0) {
    EXPECT_EQ(ReadOnlyCommitFailure(dir), "");
    return;
  }
  // Root ignores permission bits, so as root the check runs in a child process that has dropped
  // to the unprivileged user 65534 ("nobody"), which is given the store.
  constexpr uid_t kNobody = 65534;
  for (const auto& e : fs::recursive_directory_iterator(dir.path()))
    ASSERT_EQ(::chown(e.path().c_str(), kNobody, kNobody), 0) << e.path();
  ASSERT_EQ(::chown(dir.path().c_str(), kNobody, kNobody), 0);
  EXPECT_EXIT(
      {
        if (::setgid(kNobody) != 0 || ::setuid(kNobody) != 0) {
          std::fprintf(stderr, "cannot drop root privileges\n");
          std::_Exit(2);
        }
        const std::string failure = ReadOnlyCommitFailure(dir);
        std::fprintf(stderr, "%s\n", failure.empty() ? "read-only store: ok" : failure.c_str());
        std::_Exit(failure.empty() ? 0 : 1);
      },
      ::testing::ExitedWithCode(0), "read-only store: ok");
}

CalibrationStoreConfig ConfigIn(const std::string& directory, int keep_previous) {
  CalibrationStoreConfig config;
  config.directory = directory;
  config.keep_previous = keep_previous;
  return config;
}

// Fills the filesystem's free space with `path`, one page at a time, until ENOSPC.
void FillUp(const std::string& path) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0600);
  ASSERT_GE(fd, 0) << std::strerror(errno);
  const std::string page(4096, 'x');
  while (::write(fd, page.data(), page.size()) == static_cast<ssize_t>(page.size())) {
  }
  ::close(fd);
}

// A full filesystem (ENOSPC) at each write of a commit. Commits fill a small tmpfs until one
// fails: with one page left the history file fits but current.json's temp file does not, and the
// history file is taken back. Then with nothing left the history file itself fails. Each failed
// commit says "No space left on device" naming the file, changes neither memory nor disk, leaves
// no temp file, and the store loads the previous calibration; once space is freed commits work.
TEST(CalibrationStoreTest, FullFilesystemRefusesCommitAndKeepsThePreviousCalibration) {
  testing::TempDir dir;
  const testing::TmpfsMount mount(dir.file("mnt"), "size=64k,mode=0700");
  CALIBD_REQUIRE_TMPFS(mount);
  const std::string root = dir.file("mnt");
  WriteBytes(root + "/spare", std::string(8192, 's'));  // freed at the end to make room
  const CalibrationStoreConfig config = ConfigIn(root + "/store", 1000);  // nothing trimmed
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(config, &error)) << error;
  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;

  auto expect_unchanged = [&](const CalibrationStore& before,
                              const std::map<std::string, std::string>& files_before) {
    ExpectSameState(store, before);
    EXPECT_EQ(Snapshot(root), files_before);
    EXPECT_EQ(TempFilesIn(root), 0);
    CalibrationStore reopened;
    ASSERT_TRUE(reopened.Open(config, &error)) << error;
    EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
    ExpectSameState(reopened, before);
  };
  int committed = 0;
  CalibrationStore before;
  std::map<std::string, std::string> files_before;
  for (int i = 1; i <= 64; ++i) {
    before = store;
    files_before = Snapshot(root);
    if (!store.Commit(Example(i), &error)) break;
    committed = i;
  }
  ASSERT_GE(committed, 3) << "the tmpfs filled up before 3 commits: " << error;
  ASSERT_LT(committed, 64) << "64 commits fitted in 64 kB";
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
  EXPECT_NE(error.find(config.directory + "/current.json"), std::string::npos) << error;
  EXPECT_NE(error.find("(nothing changed)"), std::string::npos) << error;
  expect_unchanged(before, files_before);
  ExpectSameInput(*store.current(), Example(committed));

  // Nothing left at all: the history file cannot be written, nor the reference.
  FillUp(root + "/filler");
  files_before = Snapshot(root);
  EXPECT_FALSE(store.Commit(Example(committed + 1), &error));
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
  EXPECT_NE(error.find(config.directory + "/history/"), std::string::npos) << error;
  EXPECT_FALSE(store.SetReference(EndOfLine(), &error));
  EXPECT_NE(error.find("No space left on device"), std::string::npos) << error;
  expect_unchanged(before, files_before);

  // Space freed: the commit goes through with the next version.
  fs::remove(root + "/spare");
  fs::remove(root + "/filler");
  ASSERT_TRUE(store.Commit(Example(committed + 1), &error)) << error;
  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(config, &error)) << error;
  EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
  ASSERT_NE(reopened.current(), nullptr);
  EXPECT_EQ(reopened.current()->version, before.current()->version + 1);
  ExpectSameInput(*reopened.current(), Example(committed + 1));
  EXPECT_EQ(TempFilesIn(root), 0);
}

// The filesystem remounted read-only mid-life (mount -o remount,ro, as the kernel does on an I/O
// error with errors=remount-ro): every write fails with EROFS naming the path, memory and disk are
// unchanged, the store still loads; remounted read-write, commits work again.
TEST(CalibrationStoreTest, ReadOnlyRemountRefusesWritesAndKeepsThePreviousCalibration) {
  testing::TempDir dir;
  const testing::TmpfsMount mount(dir.file("mnt"), "size=256k,mode=0700");
  CALIBD_REQUIRE_TMPFS(mount);
  const CalibrationStoreConfig config = ConfigIn(dir.file("mnt/store"), 5);
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(config, &error)) << error;
  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;
  ASSERT_TRUE(store.Commit(Example(1), &error)) << error;
  ASSERT_TRUE(store.Commit(Example(2), &error)) << error;
  const CalibrationStore before = store;
  const auto files_before = Snapshot(config.directory);

  ASSERT_TRUE(mount.SetReadOnly(true)) << std::strerror(errno);
  EXPECT_FALSE(store.Commit(Example(3), &error));
  EXPECT_NE(error.find("Read-only file system"), std::string::npos) << error;
  EXPECT_NE(error.find(config.directory + "/history/"), std::string::npos) << error;
  EXPECT_FALSE(store.MarkVerified(1700009999, &error));
  EXPECT_NE(error.find("Read-only file system"), std::string::npos) << error;
  EXPECT_FALSE(store.RestoreReference(1700009999, &error));
  EXPECT_NE(error.find("Read-only file system"), std::string::npos) << error;
  EXPECT_FALSE(store.SetReference(EndOfLine(), &error));
  EXPECT_NE(error.find("Read-only file system"), std::string::npos) << error;
  ExpectSameState(store, before);
  EXPECT_EQ(store.current()->verified_unix_s, 0);
  EXPECT_EQ(Snapshot(config.directory), files_before);
  {
    CalibrationStore reopened;  // a restart while read-only: loads what was there
    ASSERT_TRUE(reopened.Open(config, &error)) << error;
    EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
    ExpectSameState(reopened, before);
  }

  ASSERT_TRUE(mount.SetReadOnly(false)) << std::strerror(errno);
  ASSERT_TRUE(store.Commit(Example(3), &error)) << error;
  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(config, &error)) << error;
  EXPECT_TRUE(reopened.load_warnings().empty()) << JoinWarnings(reopened);
  EXPECT_EQ(reopened.current()->version, before.current()->version + 1);
  ExpectSameInput(*reopened.current(), Example(3));
  EXPECT_EQ(TempFilesIn(config.directory), 0);
}

TEST(CalibrationStoreTest, RestoreReferenceMakesItCurrentAsANewVersion) {
  testing::TempDir dir;
  CalibrationStore store;
  std::string error;
  ASSERT_TRUE(store.Open(Config(dir), &error)) << error;
  EXPECT_FALSE(store.RestoreReference(1700000000, &error));
  EXPECT_NE(error.find("no reference"), std::string::npos) << error;

  ASSERT_TRUE(store.SetReference(EndOfLine(), &error)) << error;  // version 1
  ASSERT_TRUE(store.Commit(EndOfLine(), &error)) << error;        // version 2
  ASSERT_TRUE(store.Commit(Example(7), &error)) << error;         // version 3
  ASSERT_TRUE(store.RestoreReference(1700005000, &error)) << error;

  ASSERT_NE(store.current(), nullptr);
  const StoredCalibration& restored = *store.current();
  EXPECT_EQ(restored.version, 4);
  EXPECT_EQ(restored.replaced_version, 3);
  EXPECT_TRUE(restored.T_camera_lidar.matrix() == EndOfLine().T_camera_lidar.matrix());
  EXPECT_EQ(restored.source, "end_of_line");
  EXPECT_EQ(restored.verdict, "restored_reference");
  EXPECT_EQ(restored.created_unix_s, 1700005000);
  EXPECT_EQ(restored.verified_unix_s, 0);
  EXPECT_NEAR(
      restored.delta_rotation_deg,
      RotationAngle(Example(7).T_camera_lidar.linear(), EndOfLine().T_camera_lidar.linear()) *
          kRad2Deg,
      1e-12);
  EXPECT_EQ(Versions(store.history()), (std::vector<int64_t>{3, 2}));
  EXPECT_EQ(store.reference()->version, 1);  // the reference itself is unchanged

  CalibrationStore reopened;
  ASSERT_TRUE(reopened.Open(Config(dir), &error)) << error;
  ExpectSameState(store, reopened);

  // A reference for other sensors is not restored over the current calibration.
  StoredCalibration swapped = Example(8);
  swapped.camera_serial = "CAM-0099";
  ASSERT_TRUE(store.Commit(swapped, &error)) << error;
  EXPECT_FALSE(store.RestoreReference(1700006000, &error));
  EXPECT_NE(error.find("CAM-0099"), std::string::npos) << error;
  EXPECT_EQ(store.current()->version, 5);
}

// What a run of SIGKILL rounds saw. A kill that landed inside a commit shows either as the
// version in flight having got through (loaded == acknowledged + 1: the kill came after its
// history file was renamed into place, before the writer could acknowledge) or as a temp file
// left behind (the kill came between creating and renaming one).
struct KillStats {
  int rounds = 0;
  int in_flight_loaded = 0;   // loaded version == last acknowledged + 1
  int acknowledged_only = 0;  // loaded version == last acknowledged
  int temp_file_left = 0;     // rounds that left at least one temp file
  int64_t commits = 0;        // versions committed over the run (the last loaded one)
  int64_t median_commit_us = 0;
};

// Tier 3: a writer committing in a loop is SIGKILLed at random moments. After each kill the store
// loads, the current version is the last acknowledged one or the one in flight, and the current
// and history hold exactly what was committed under those versions. Plain failures are recorded
// with ADD_FAILURE and end the run.
KillStats RunSigkillRounds(const CalibrationStoreConfig& config, int rounds, uint32_t seed) {
  // Kill moments spread uniformly over about two commits. A commit is a few fsyncs whose cost
  // depends on the disk and on the build (a forked AddressSanitizer process pays for copying its
  // shadow memory), so the writer measures its own first commit of the round and reports it.
  KillStats stats;
  std::mt19937 rng(seed);
  std::vector<int64_t> commit_us_seen;
  int64_t acknowledged = 0;
  for (int round = 0; round < rounds; ++round) {
    int fds[2];
    if (::pipe(fds) != 0) {
      ADD_FAILURE() << "pipe: " << std::strerror(errno);
      return stats;
    }
    const pid_t child = ::fork();
    if (child < 0) {
      ADD_FAILURE() << "fork: " << std::strerror(errno);
      return stats;
    }
    if (child == 0) {
      ::close(fds[0]);
      CalibrationStore store;
      std::string error;
      if (!store.Open(config, &error)) ::_exit(2);
      const auto start = std::chrono::steady_clock::now();
      const int64_t first = store.current() ? store.current()->version + 1 : 1;
      if (!store.Commit(Example(static_cast<int>(first)), &error)) ::_exit(3);
      const int64_t took_us = std::chrono::duration_cast<std::chrono::microseconds>(
                                  std::chrono::steady_clock::now() - start)
                                  .count();
      if (::write(fds[1], &took_us, sizeof(took_us)) != sizeof(took_us)) ::_exit(4);
      if (::write(fds[1], &first, sizeof(first)) != sizeof(first)) ::_exit(4);
      for (;;) {
        const int64_t next = store.current() ? store.current()->version + 1 : 1;
        if (!store.Commit(Example(static_cast<int>(next)), &error)) ::_exit(3);
        if (::write(fds[1], &next, sizeof(next)) != sizeof(next)) ::_exit(4);
      }
    }
    ::close(fds[1]);
    int64_t commit_us = 0, v = -1;
    const bool started = ::read(fds[0], &commit_us, sizeof(commit_us)) ==
                         static_cast<ssize_t>(sizeof(commit_us));  // opened and committed once
    if (started) {
      commit_us_seen.push_back(commit_us);
      std::uniform_int_distribution<int64_t> delay_us(0, 2 * commit_us + 100);
      std::this_thread::sleep_for(std::chrono::microseconds(delay_us(rng)));
    }
    ::kill(child, SIGKILL);
    int status = 0;
    if (::waitpid(child, &status, 0) != child || !WIFSIGNALED(status)) {
      ADD_FAILURE() << "round " << round << ": writer exited with " << WEXITSTATUS(status);
      ::close(fds[0]);
      return stats;
    }
    while (::read(fds[0], &v, sizeof(v)) == sizeof(v)) acknowledged = std::max(acknowledged, v);
    ::close(fds[0]);
    if (!started) {
      ADD_FAILURE() << "round " << round << ": the writer did not commit once";
      return stats;
    }
    if (TempFilesIn(config.directory) > 0) ++stats.temp_file_left;

    CalibrationStore store;
    std::string error;
    if (!store.Open(config, &error)) {
      ADD_FAILURE() << "round " << round << ": " << error;
      return stats;
    }
    if (store.current() == nullptr) {
      ADD_FAILURE() << "round " << round << ": no current calibration\n" << JoinWarnings(store);
      return stats;
    }
    const int64_t version = store.current()->version;
    EXPECT_GE(version, acknowledged) << "round " << round;
    EXPECT_LE(version, acknowledged + 1) << "round " << round;
    ExpectSameInput(*store.current(), Example(static_cast<int>(version)));
    for (size_t i = 0; i < store.history().size(); ++i) {
      const int64_t expected = version - 1 - static_cast<int64_t>(i);
      EXPECT_EQ(store.history()[i].version, expected);
      ExpectSameInput(store.history()[i], Example(static_cast<int>(expected)));
    }
    EXPECT_EQ(store.history().size(),
              static_cast<size_t>(std::min<int64_t>(config.keep_previous, version - 1)));
    if (version == acknowledged + 1) ++stats.in_flight_loaded;
    if (version == acknowledged) ++stats.acknowledged_only;
    acknowledged = version;
    ++stats.rounds;
    if (::testing::Test::HasFailure()) {
      ADD_FAILURE() << "round " << round;
      return stats;
    }
  }
  stats.commits = acknowledged;
  std::sort(commit_us_seen.begin(), commit_us_seen.end());
  if (!commit_us_seen.empty()) stats.median_commit_us = commit_us_seen[commit_us_seen.size() / 2];
  std::printf(
      "%d SIGKILLs: %lld versions committed (commit about %lld us); loaded the version in "
      "flight %d times, the acknowledged one %d times; a temp file was left %d times\n",
      stats.rounds, static_cast<long long>(stats.commits),
      static_cast<long long>(stats.median_commit_us), stats.in_flight_loaded,
      stats.acknowledged_only, stats.temp_file_left);
  return stats;
}

TEST(CalibrationStoreTest, SurvivesSigkillAtAnyMoment) {
  testing::TempDir dir;
  constexpr int kRounds = 40;
  const KillStats stats = RunSigkillRounds(Config(dir, 3), kRounds, 7);
  ASSERT_EQ(stats.rounds, kRounds);
  // At least one commit per round (the measured one), about two expected: the kills landed
  // during commits, not after the writer had stopped.
  EXPECT_GE(stats.commits, kRounds);
}

// The power-loss figure: 500 kills (labelled slow in tests/CMakeLists.txt, several seconds
// of fsyncs). Besides every load being whole, enough kills must have landed inside a commit:
// the version in flight loaded, or a temp file left behind.
TEST(CalibrationStoreTest, SurvivesFiveHundredSigkills) {
  testing::TempDir dir;
  constexpr int kRounds = 500;
  const KillStats stats = RunSigkillRounds(Config(dir, 3), kRounds, 2026);
  ASSERT_EQ(stats.rounds, kRounds);
  EXPECT_GE(stats.commits, kRounds);
  EXPECT_EQ(stats.in_flight_loaded + stats.acknowledged_only, kRounds);
  EXPECT_GE(stats.in_flight_loaded, kRounds / 10);
  EXPECT_GE(stats.acknowledged_only, kRounds / 10);
  EXPECT_GE(stats.temp_file_left, kRounds / 20);
}

}  // namespace
}  // namespace calibd
