#pragma once
/// \file
/// The session marker: a small file the agent writes, atomically, when a session
/// starts and removes when it ends with any outcome or on a clean stop. One found at start-up
/// means the previous run stopped during that session (SIGKILL, crash, power loss): the agent
/// reports it (DTC 5A0300) and starts idle with the stored calibration, which a session never
/// changes before its result is committed.
///
/// File `<agent.store.directory>/session_in_progress` (the calibration store reads only
/// current.json, reference.json and history/, so it ignores it):
///   calibd-session 1
///   session <n>
///   trigger <requester, printable ASCII>
///   started_unix_s <s>
///   end

#include <cstdint>
#include <string>

namespace calibd {

struct SessionMarker {
  int session = 0;             ///< the run's session number (1 for its first)
  std::string trigger;         ///< who started it: "--calibrate-now", "start_button", "uds", ...
  int64_t started_unix_s = 0;  ///< wall clock at the start
};

/// `<store_directory>/session_in_progress`.
std::string SessionMarkerPath(const std::string& store_directory);

/// Writes `marker` to `path` atomically; false with `error` (the session runs anyway).
bool WriteSessionMarker(const std::string& path, const SessionMarker& marker, std::string* error);

enum class MarkerRead { kNone, kFound, kUnreadable };
/// Reads the marker at `path`: kNone when there is none, kFound with `marker` filled, or
/// kUnreadable (damaged or cut short) with `error` saying why; a damaged marker still means a run
/// stopped during a session.
MarkerRead ReadSessionMarker(const std::string& path, SessionMarker* marker, std::string* error);

/// Removes the marker and any temp file an interrupted write left beside it; false with `error`
/// when it exists and cannot be removed.
bool RemoveSessionMarker(const std::string& path, std::string* error);

/// The agent's marker file: its previous run's at start-up, then one per session.
class SessionMarkerFile {
 public:
  /// The marker of the store in `store_directory`.
  void Open(const std::string& store_directory) { path_ = SessionMarkerPath(store_directory); }
  /// At start-up: when the previous run left a marker, the log line that tells of it ("the
  /// previous run stopped during session 3 (started by ...) without a result: ..."), and the
  /// marker removed (a removal failure in `error`); empty when there was none.
  std::string TakeInterrupted(std::string* error);
  /// A session starts: writes its marker; false with `error` when it could not (the session runs
  /// anyway, only the report of a later interruption is lost).
  bool Begin(const SessionMarker& marker, std::string* error);
  /// The session ended (any outcome) or the agent stops cleanly: removes the marker Begin wrote.
  /// True when there was none or it is gone.
  bool End(std::string* error);

 private:
  std::string path_;
  int session_ = 0;  ///< the session the written marker names; 0: none written
};

}  // namespace calibd
