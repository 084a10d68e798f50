#pragma once
/// \file
/// Whole-file writes that are never seen half-done: temp file in the same directory, fsync, rename
/// over the target, fsync of the directory (POSIX rename is atomic within a filesystem).

#include <string>
#include <string_view>

namespace calibd {

/// Replaces `path` with `contents`. On failure the old file is untouched, the temp file is removed
/// and `error` names the path and the system error.
bool WriteFileAtomic(const std::string& path, std::string_view contents, std::string* error);

/// Reads a whole file; false with `error` naming the path when it cannot be read.
bool ReadWholeFile(const std::string& path, std::string* contents, std::string* error);

/// Creates directory `path` and its missing parents (an existing one is fine); false with `error`
/// naming the path and the system error.
bool CreateDirectories(const std::string& path, std::string* error);

}  // namespace calibd
