// The calibration config (calibd-calibrate's --config, the agent's `calibration` block) as
// LoadConfigFile parses it: ParseConfigYaml on the file's text; what it accepts must round-trip
// through ConfigToYaml.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/config_file.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string text(reinterpret_cast<const char*>(data), size);
  calibd::CalibConfig config;
  std::string error;
  if (!calibd::ParseConfigYaml(text, &config, &error)) {
    Check(!error.empty(), "a refused config names the key");
    return 0;
  }
  const std::string yaml = calibd::ConfigToYaml(config);
  calibd::CalibConfig again;
  Check(calibd::ParseConfigYaml(yaml, &again, &error), "ConfigToYaml's text parses");
  Check(calibd::ConfigToYaml(again) == yaml, "the config round-trips");
  return 0;
}
