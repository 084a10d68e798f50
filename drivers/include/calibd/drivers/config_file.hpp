#pragma once
/// \file
/// The calibration config as a YAML file (keys documented in deploy/config/ and the README).
/// Loading validates every key once; errors name the key and the file.

#include <string>

#include "calibd/core/config.hpp"

namespace calibd {

/// Parses YAML text. On failure `error` reads "<key>: <what is wrong>".
bool ParseConfigYaml(const std::string& text, CalibConfig* config, std::string* error);

/// Loads and validates `path`. On failure `error` starts with the path.
bool LoadConfigFile(const std::string& path, CalibConfig* config, std::string* error);

/// YAML text of a config (round-trips through ParseConfigYaml).
std::string ConfigToYaml(const CalibConfig& config);

/// Writes the config atomically.
bool SaveConfigFile(const std::string& path, const CalibConfig& config, std::string* error);

}  // namespace calibd
