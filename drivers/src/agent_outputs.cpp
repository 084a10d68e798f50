#include "calibd/drivers/agent_outputs.hpp"

#include <algorithm>
#include <lcm/lcm-cpp.hpp>

#include "calibd/channels.hpp"

namespace calibd {

namespace {

// Decodes `ev` into `msg`; counts it in `count` or, when it does not decode whole, in `bad`.
template <typename Msg>
bool Decode(const lcm::LogEvent& ev, Msg* msg, int* count, int* bad) {
  const int size = static_cast<int>(ev.datalen);
  if (msg->decode(ev.data, 0, size) != size) {
    ++*bad;
    return false;
  }
  ++*count;
  return true;
}

}  // namespace

bool ReadAgentOutputs(const std::string& log_path, AgentOutputs* out, std::string* error) {
  *out = AgentOutputs{};
  lcm::LogFile log(log_path, "r");
  if (!log.good()) {
    if (error) *error = "cannot read the agent's published log " + log_path;
    return false;
  }
  while (const lcm::LogEvent* ev = log.readNextEvent()) {
    if (ev->channel == channels::kStatus.name) {
      Decode(*ev, &out->last_status, &out->status, &out->undecodable);
    } else if (ev->channel == channels::kResult.name) {
      Decode(*ev, &out->last_result, &out->results, &out->undecodable);
    } else if (ev->channel == channels::kHealth.name &&
               Decode(*ev, &out->last_health, &out->health, &out->undecodable)) {
      out->max_camera_rate_hz = std::max(out->max_camera_rate_hz, out->last_health.camera_rate_hz);
      out->max_lidar_rate_hz = std::max(out->max_lidar_rate_hz, out->last_health.lidar_rate_hz);
    }
  }
  return true;
}

}  // namespace calibd
