#include "uds_client.hpp"

#include <poll.h>
#include <time.h>

#include <cstdio>

#include "calibd/agent/uds/uds_types.hpp"
#include "uds_decode.hpp"

namespace calibd::tester {

int64_t MonotonicUs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000 + ts.tv_nsec / 1000;
}

bool UdsClient::Open(const IsoTpConfig& config, const ClientTiming& timing, std::string* error) {
  config_ = config;
  timing_ = timing;
  if (!transport_.Start(config, MonotonicUs(), error)) return false;
  if (transport_.fd() < 0) {
    const std::string why = transport_.status().last_error;
    *error = "interface " + config.interface + " is not usable" +
             (why.empty() ? std::string() : ": " + why) +
             " (check that it exists and is up: ip link show " + config.interface + ")";
    return false;
  }
  return true;
}

std::string UdsClient::Describe(uint8_t sid) const {
  char ids[64];
  std::snprintf(ids, sizeof(ids), " (0x%X -> 0x%X)", config_.physical_request_id,
                config_.physical_response_id);
  char sid_text[8];
  std::snprintf(sid_text, sizeof(sid_text), "0x%02X", sid);
  return std::string(sid_text) + " " + ServiceName(sid) + " on " + config_.interface + ids;
}

namespace {

// Whether a positive response echoes this request's identifiers (ISO 14229-1: 0x22/0x2E the DID,
// 0x31 the control type and RID, services with a sub-function the sub-function without the
// suppress bit). A late answer to an earlier request of the same service must not pass for it.
bool EchoMatches(const std::vector<uint8_t>& req, const uint8_t* m, size_t size) {
  // Bytes [1, 1 + count) of the request and the response; `sub_function`: byte 1 compared
  // without the suppressPosRspMsgIndicationBit. A request too short to have them (raw) passes.
  auto same = [&](size_t count, bool sub_function) {
    if (req.size() < 1 + count) return true;
    if (size < 1 + count) return false;
    for (size_t i = 1; i < 1 + count; ++i) {
      const uint8_t a = sub_function && i == 1 ? static_cast<uint8_t>(req[i] & 0x7F) : req[i];
      if (a != m[i]) return false;
    }
    return true;
  };
  switch (req[0]) {
    case uds::kSidReadDataByIdentifier:
    case uds::kSidWriteDataByIdentifier:
      return same(2, false);
    case uds::kSidRoutineControl:
      return same(3, true);
    case uds::kSidDiagnosticSessionControl:
    case uds::kSidEcuReset:
    case uds::kSidReadDtcInformation:
    case uds::kSidSecurityAccess:
    case uds::kSidTesterPresent:
    case uds::kSidControlDtcSetting:
      return same(1, true);
    default:
      return true;
  }
}

}  // namespace

UdsReply UdsClient::Request(const std::vector<uint8_t>& request, bool functional,
                            bool expect_response) {
  UdsReply reply;
  IsoTpMessage message;
  // Late answers to an earlier request (after our timeout) must not pass for this one's.
  while (transport_.Receive(&message) == IsoTpIo::kOk) {
  }
  const int64_t start_us = MonotonicUs();
  IsoTpIo io = IsoTpIo::kBusy;
  // kBusy: the kernel still sends the previous message's consecutive frames (N_Bs is 1 s).
  while (io == IsoTpIo::kBusy && MonotonicUs() - start_us < 1500 * 1000) {
    io = functional ? transport_.SendFunctional(request.data(), request.size())
                    : transport_.SendPhysical(request.data(), request.size());
    if (io == IsoTpIo::kBusy) ::poll(nullptr, 0, 5);
  }
  last_request_us_ = MonotonicUs();
  if (io != IsoTpIo::kOk) {
    reply.outcome = io == IsoTpIo::kLinkDown ? UdsReply::Outcome::kLinkDown
                                             : UdsReply::Outcome::kTransportError;
    reply.error = transport_.status().last_error;
    if (reply.error.empty()) reply.error = ToString(io);
    return reply;
  }
  const uint8_t sid = request[0];
  int64_t deadline_us = last_request_us_ + int64_t{timing_.p2_ms} * 1000;
  for (;;) {
    const int64_t now_us = MonotonicUs();
    reply.waited_ms = static_cast<int>((now_us - start_us) / 1000);
    if (now_us >= deadline_us) {
      reply.outcome =
          expect_response ? UdsReply::Outcome::kTimeout : UdsReply::Outcome::kNoResponse;
      return reply;
    }
    pollfd pfd{transport_.fd(), POLLIN, 0};
    const int wait_ms = static_cast<int>((deadline_us - now_us + 999) / 1000);
    if (pfd.fd < 0) {
      reply.outcome = UdsReply::Outcome::kLinkDown;
      reply.error = transport_.status().last_error;
      return reply;
    }
    if (::poll(&pfd, 1, wait_ms) <= 0) continue;
    io = transport_.Receive(&message);
    if (io == IsoTpIo::kNone) continue;
    if (io != IsoTpIo::kOk) {
      reply.outcome = io == IsoTpIo::kLinkDown ? UdsReply::Outcome::kLinkDown
                                               : UdsReply::Outcome::kTransportError;
      reply.error = transport_.status().last_error;
      return reply;
    }
    const uint8_t* m = message.data;
    if (message.size >= 3 && m[0] == uds::kSidNegativeResponse && m[1] == sid) {
      if (m[2] == 0x78) {  // responsePending: the ECU needs up to P2* more (ISO 14229-2 §7.2)
        ++reply.pending_count;
        deadline_us = MonotonicUs() + int64_t{timing_.p2_star_ms} * 1000;
        continue;
      }
      reply.outcome = UdsReply::Outcome::kNegative;
      reply.nrc = m[2];
      reply.bytes.assign(m, m + message.size);
      return reply;
    }
    if (message.size >= 1 && m[0] == static_cast<uint8_t>(sid + uds::kPositiveResponseOffset) &&
        EchoMatches(request, m, message.size)) {
      reply.outcome = UdsReply::Outcome::kPositive;
      reply.bytes.assign(m, m + message.size);
      reply.waited_ms = static_cast<int>((MonotonicUs() - start_us) / 1000);
      return reply;
    }
    // Anything else answers another request (or another tester's): not ours, keep waiting.
  }
}

void UdsClient::KeepAlive() {
  const int64_t now_us = MonotonicUs();
  if (now_us - last_request_us_ < int64_t{timing_.tester_present_period_ms} * 1000) return;
  const uint8_t request[2] = {uds::kSidTesterPresent, uds::kSuppressPosRspBit};
  transport_.SendFunctional(request, sizeof(request));
  last_request_us_ = now_us;
}

}  // namespace calibd::tester
