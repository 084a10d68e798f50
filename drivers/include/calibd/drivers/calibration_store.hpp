#pragma once
/// \file
/// The on-vehicle calibration store: one directory holding the current T_camera_lidar, the
/// factory/end-of-line reference and the last N previous versions.
///
/// Layout (one JSON file per calibration, each with a format version and a CRC-32):
///   <directory>/current.json          the current calibration (a second copy of the newest)
///   <directory>/reference.json        the factory / end-of-line reference
///   <directory>/history/v000007.json  every committed version still kept, the current included
///
/// Every file is replaced with WriteFileAtomic (temp file, fsync, rename, fsync of the directory),
/// and a commit writes history/vN.json before current.json. So a crash at any moment leaves either
/// the old or the new calibration loadable, never a mixture and never nothing:
/// - On load, the current calibration is the valid copy with the highest version (ties: the later
///   verified_unix_s), whether it sits in current.json or in history/. A commit interrupted after
///   its history file was written is therefore completed on the next load; a corrupt, truncated
///   or missing current.json falls back to the newest valid history file.
/// - Version numbers come from every file name and every valid file seen, so they never go
///   backwards or get reused, even when the newest file is the corrupt one.
/// - A file that fails its checks is skipped and the reason is kept in load_warnings() (e.g.
///   "current.json: checksum mismatch (file corrupt or truncated), using version 7 from
///   history/v000007.json"); the corrupt file stays on disk for diagnosis until trimmed.
///
/// One process writes a store directory at a time (the agent); readers may open it any time.

#include <cstdint>
#include <string>
#include <vector>

#include "calibd/core/common/geometry.hpp"

namespace calibd {

/// One stored LiDAR-camera calibration with the figures that justified it. A value type.
struct StoredCalibration {
  /// Store-wide sequence number (1, 2, ...), assigned by the store on Commit/SetReference: it
  /// increases with every calibration written, current and reference alike, so gaps are normal.
  int64_t version = 0;
  /// Version of the calibration this one replaced (the previous current, or for the reference the
  /// previous reference); 0 when it replaced nothing. Assigned by the store.
  int64_t replaced_version = 0;
  int64_t created_unix_s = 0;   ///< when the calibration was produced (caller's clock), s
  int64_t verified_unix_s = 0;  ///< last time a `verified` verdict confirmed it; 0: never
  /// Maps LiDAR points into the camera frame: p_camera = T_camera_lidar * p_lidar.
  Pose T_camera_lidar = Pose::Identity();
  std::string lidar_serial, camera_serial;  ///< the sensors it belongs to; both required
  std::string source;  ///< where it came from: "factory", "end_of_line", "workshop", "on_vehicle"
  /// Why it became a calibration: "updated" (engine verdict), "end_of_line", "restored_reference",
  /// ... Never "rejected": a rejected result is not stored.
  std::string verdict;
  // Quality figures of the session that produced it (0 when unknown, e.g. a factory value).
  double reprojection_mean_px = 0.0;  ///< paper Table I metric
  double residual_rms_m = 0.0;        ///< LiDAR board points to their boards
  double rotation_sigma_deg = 0.0;    ///< formal standard deviations
  double translation_sigma_m = 0.0;
  /// The session's predicted 99 % bound on this result's own error (QualityFigures: clustered
  /// covariance plus the systematic terms); 0 when unknown (a factory value, a file of format 1).
  double rotation_bound_deg = 0.0, translation_bound_m = 0.0;
  int frames_used = 0, boards_used = 0;
  /// Change from the calibration it replaced (see replaced_version), computed by the store.
  double delta_rotation_deg = 0.0, delta_translation_m = 0.0;

  /// Checks the fields a caller supplies (version and the replaced_version/delta fields are the
  /// store's): a proper rotation in T_camera_lidar, non-empty serials, source and verdict, a
  /// verdict other than "rejected", finite non-negative figures and times. On failure `error`
  /// names the field, e.g. "lidar_serial: must not be empty".
  bool IsValid(std::string* error) const;
};

/// Parses the text of one stored calibration file (what CalibrationStore::Open reads for each
/// file): format, format version, known fields only, CRC-32 and content checks. False with `error`
/// saying what is wrong (e.g. "checksum mismatch (file corrupt or truncated)"); `c` is then
/// untouched.
bool ParseCalibrationFile(const std::string& text, StoredCalibration* c, std::string* error);

struct CalibrationStoreConfig {
  std::string directory;  ///< created (mode 0700) if missing; its parent must exist
  /// Previous versions kept besides the current one. More keep older calibrations to go back to;
  /// each costs one small file (~1 kB).
  int keep_previous = 5;

  /// On failure `error` names the key, e.g. "keep_previous: must be >= 0 (got -1)".
  bool IsValid(std::string* error) const;
};

class CalibrationStore {
 public:
  /// Creates the directory if missing and loads what it holds. Returns false (with `error`
  /// naming the path) only when the directory cannot be created or read; unusable files are
  /// skipped and reported in load_warnings(). Any earlier state of this object is dropped.
  bool Open(const CalibrationStoreConfig& config, std::string* error);

  /// The current calibration; nullptr when the store holds none (new store, or every copy bad).
  const StoredCalibration* current() const { return has_current_ ? &current_ : nullptr; }
  /// The factory / end-of-line reference; nullptr when none is set or reference.json is bad.
  const StoredCalibration* reference() const { return has_reference_ ? &reference_ : nullptr; }
  /// Previous versions, newest first, at most keep_previous.
  const std::vector<StoredCalibration>& history() const { return history_; }
  /// What Open skipped and why, one line per file, naming the file.
  const std::vector<std::string>& load_warnings() const { return load_warnings_; }

  /// Makes `c` the current calibration as the next version (assigned here together with
  /// replaced_version and the deltas from the current it replaces); the old current moves into
  /// the history, which is trimmed to keep_previous. On failure (invalid `c`, storage error)
  /// neither memory nor disk changes and `error` names the field or the path.
  bool Commit(const StoredCalibration& c, std::string* error);

  /// Records that a `verified` verdict confirmed the current calibration at `unix_s`. Fails when
  /// there is no current calibration; on failure nothing changes.
  bool MarkVerified(int64_t unix_s, std::string* error);

  /// Stores `c` as the reference (replacing any earlier one) with the next version number.
  bool SetReference(const StoredCalibration& c, std::string* error);

  /// Commits a copy of the reference as a new current version created at `unix_s` (verdict
  /// "restored_reference", never verified yet). Fails when there is no reference, or when its
  /// sensor serials differ from the current calibration's: a reference for another sensor would
  /// put a wrong extrinsic in place silently.
  bool RestoreReference(int64_t unix_s, std::string* error);

 private:
  std::string PathOf(const std::string& name) const { return config_.directory + "/" + name; }
  /// Best effort after a commit: removes history files older than the kept versions and temp
  /// files left by interrupted writes. A file it cannot remove is harmless and retried next time.
  void Trim();

  CalibrationStoreConfig config_;
  bool open_ = false;
  bool has_current_ = false, has_reference_ = false;
  StoredCalibration current_, reference_;
  /// Whether history/ holds a valid copy identical to current_ (checked at load, kept by every
  /// write). Commit rewrites the copy first when it does not, so the old current is never lost.
  bool current_in_history_ = false;
  std::vector<StoredCalibration> history_;
  std::vector<std::string> load_warnings_;
  int64_t next_version_ = 1;
};

}  // namespace calibd
