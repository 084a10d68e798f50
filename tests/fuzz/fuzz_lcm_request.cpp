// LCM calibration_request_t bytes (start/stop/commit/verify) as the agent receives them: decoded
// like LcmBus, converted into a StartRequest as Agent::OnRequest does, and fed to the session
// state machine with the default agent config.

#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/session_machine.hpp"
#include "calibd/calibration_request_t.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::calibration_request_t;
  calibration_request_t msg;
  if (!calibd::fuzz::DecodeLikeTheBus(data, size, &msg)) return 0;
  static const calibd::SessionConfig config = calibd::SessionConfigFrom(calibd::AgentConfig{});
  calibd::SessionMachine machine(config);
  const int64_t now_us = 1000000;
  // Agent::OnRequest (agent.cpp).
  if (msg.action == calibration_request_t::ACTION_START ||
      msg.action == calibration_request_t::ACTION_VERIFY) {
    calibd::StartRequest r;
    r.mode = msg.mode == calibration_request_t::MODE_STATIC ? calibd::SessionMode::kStatic
                                                            : calibd::SessionMode::kMoving;
    r.max_duration_us = static_cast<int64_t>(std::max(0, msg.max_duration_ms)) * 1000;
    r.verify_only = msg.action == calibration_request_t::ACTION_VERIFY;
    r.requester = msg.requester;
    const calibd::RequestReply reply = machine.Start(r, now_us);
    calibd::fuzz::Check(reply.accepted || !reply.reason.empty(), "a refused start says why");
    machine.Tick(now_us + r.max_duration_us + 1);
  } else if (msg.action == calibration_request_t::ACTION_STOP) {
    const calibd::RequestReply reply = machine.Stop(now_us);
    calibd::fuzz::Check(!reply.accepted, "nothing to stop in a fresh machine");
  }
  return 0;
}
