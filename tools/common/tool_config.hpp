#pragma once
/// \file
/// What calibd-calibrate and calibd-import share of their inputs: the calibration config with
/// --intrinsics from another tool replacing its camera section, and the help text's description
/// of a recorded folder's frames.csv.

#include <string>
#include <vector>

#include "calibd/core/session/config.hpp"

namespace calibd::tools {

/// Reads --config `config_path` into `config` (its text into `text`, for the sections the caller
/// parses itself: `other_sections`, e.g. the agent's `engine:`), with the intrinsics of
/// `intrinsics_path`, when not empty, replacing the config's camera section, which may then be
/// left out or hold only id and frame_id. False with `error` naming the file and the key.
bool LoadToolConfig(const std::string& config_path, const std::string& intrinsics_path,
                    const std::vector<std::string>& other_sections, CalibConfig* config,
                    std::string* text, std::string* error);

/// `help` with its %CSV% replaced by the frames.csv description (recorded_folder.hpp).
std::string HelpWithFramesCsv(const char* help);

}  // namespace calibd::tools
