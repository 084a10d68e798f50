#pragma once
/// \file
/// The calibration config as a YAML file (keys documented in deploy/config/ and
/// docs/offline-tools.md). Loading validates every key once; errors name the key and the file.

#include <string>
#include <vector>

#include "calibd/core/common/text_format.hpp"
#include "calibd/core/session/config.hpp"
#include "calibd/drivers/atomic_file.hpp"

namespace calibd {

/// What a caller adds to the calibration config's own keys.
struct ConfigParseOptions {
  /// Intrinsics from elsewhere (calibd-calibrate --intrinsics): they replace the `camera:`
  /// section's, which may then be left out (or hold only `id` and `frame_id`).
  const CameraIntrinsics* intrinsics = nullptr;
  /// Top-level sections the caller parses itself (the agent's `agent:` and `engine:`); any other
  /// unknown key is an error.
  std::vector<std::string> other_sections;
};

/// Parses YAML text. On failure `error` reads "<key>: <what is wrong>".
bool ParseConfigYaml(const std::string& text, CalibConfig* config, std::string* error,
                     const ConfigParseOptions& options = {});

/// Loads and validates `path`. On failure `error` starts with the path.
bool LoadConfigFile(const std::string& path, CalibConfig* config, std::string* error);

/// Reads `path` and parses its text with `parse` (e.g. ParseConfigYaml); on failure `error`
/// starts with the path (or is the read error, which names it).
template <typename Config>
bool LoadTextFile(const std::string& path,
                  bool (*parse)(const std::string& text, Config* config, std::string* error),
                  Config* config, std::string* error) {
  std::string text, why;
  if (!ReadWholeFile(path, &text, error)) return false;
  if (!parse(text, config, &why)) {
    if (error) *error = path + ": " + why;
    return false;
  }
  return true;
}

/// YAML text of a config (round-trips through ParseConfigYaml).
std::string ConfigToYaml(const CalibConfig& config);

/// Shortest decimal text that reads back to the same double (0.48, not 0.47999999999999998).
std::string ShortestDecimal(double v);

/// Writes the config atomically.
bool SaveConfigFile(const std::string& path, const CalibConfig& config, std::string* error);

}  // namespace calibd
