#include "tool_config.hpp"

#include "calibd/drivers/atomic_file.hpp"
#include "calibd/drivers/config_file.hpp"
#include "calibd/drivers/intrinsics_file.hpp"
#include "calibd/drivers/recorded_folder.hpp"

namespace calibd::tools {

bool LoadToolConfig(const std::string& config_path, const std::string& intrinsics_path,
                    const std::vector<std::string>& other_sections, CalibConfig* config,
                    std::string* text, std::string* error) {
  CameraIntrinsics intrinsics;
  if (!intrinsics_path.empty() && !LoadIntrinsicsFile(intrinsics_path, &intrinsics, error)) {
    *error = "--intrinsics: " + *error;
    return false;
  }
  ConfigParseOptions options;
  options.intrinsics = intrinsics_path.empty() ? nullptr : &intrinsics;
  options.other_sections = other_sections;
  if (!ReadWholeFile(config_path, text, error)) return false;
  if (!ParseConfigYaml(*text, config, error, options)) {
    *error = config_path + ": " + *error;
    return false;
  }
  return true;
}

std::string HelpWithFramesCsv(const char* help) {
  std::string text = help;
  const size_t at = text.find("%CSV%");
  if (at != std::string::npos) text.replace(at, 5, kFramesCsvHelp);
  return text;
}

}  // namespace calibd::tools
