// The agent's config file (calibd.yaml: calibration, agent, engine, UDS keys) as LoadAgentConfig
// parses and validates it: ParseAgentConfigYaml on the file's text.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string text(reinterpret_cast<const char*>(data), size);
  calibd::AgentConfig config;
  std::string error;
  if (!calibd::ParseAgentConfigYaml(text, &config, &error)) {
    Check(!error.empty(), "a refused config names the key");
    return 0;
  }
  // Accepted means validated: IsValid must agree with the parser.
  Check(config.IsValid(&error), "an accepted config is valid");
  return 0;
}
