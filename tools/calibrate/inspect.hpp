#pragma once
/// \file
/// calibd-calibrate --inspect: a new user's first look at a folder of recorded frames. Per frame,
/// the tags (family, id, size) and checkerboards the camera shows and the LiDAR's points, rings
/// and likely model; then a starter config with those boards, that model and a nominal prior from
/// a named mounting, TODO where only a tape measure can tell (board and tag sizes, the lever arm).

#include <iosfwd>
#include <string>

namespace calibd::tools {

struct InspectOptions {
  std::string folder;
  std::string intrinsics_path;  ///< optional: then the starter config's camera needs only its id
  std::string mounting = "forward";
  std::string config_out;  ///< the starter config; empty: printed after the table
};

/// The mountings a nominal prior can be built from (for --help and errors).
const char* InspectMountings();

/// Prints the survey to `out`, problems to `err`; returns the exit code (0, or 2 for bad options
/// or an unreadable folder). A file that cannot be read is named and skipped.
int RunInspect(const InspectOptions& options, std::ostream& out, std::ostream& err);

}  // namespace calibd::tools
