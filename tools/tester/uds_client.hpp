#pragma once
/// \file
/// The tester side of UDS (ISO 14229-1) over calibd's ISO-TP client transport: one request, one
/// response, with the client timing of ISO 14229-2 §7.2 (Table 4):
/// - after the request, wait up to P2client for the response;
/// - a negative response 0x78 requestCorrectlyReceived-ResponsePending extends the wait to
///   P2*client (again after every further 0x78);
/// - TesterPresent 0x3E 0x80 (suppressed positive response) keeps a non-default session alive
///   while the tester waits between requests (S3server is 5 s, we send every 2 s, §9.3).
/// P2client and P2*client must exceed the server's P2/P2* (50 ms / 5000 ms for calibd) plus the
/// bus and scheduling delays; the defaults leave 150 ms / 500 ms for those.

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "calibd/drivers/isotp_channel.hpp"

namespace calibd::tester {

struct ClientTiming {
  int p2_ms = 200;        ///< wait for a response
  int p2_star_ms = 5500;  ///< wait after each 0x78 responsePending
  int tester_present_period_ms = 2000;
};

/// What one request got.
struct UdsReply {
  enum class Outcome {
    kPositive,        ///< `bytes` holds the positive response (SID + 0x40 first)
    kNegative,        ///< `nrc` holds the final negative response code
    kNoResponse,      ///< none was expected (suppressed positive response) and none came
    kTimeout,         ///< nothing within P2 (P2* after 0x78): `waited_ms`, `pending_count`
    kLinkDown,        ///< the interface is down or gone: `error`
    kTransportError,  ///< ISO-TP failed (no flow control, sequence error): `error`
  };
  Outcome outcome = Outcome::kTimeout;
  std::vector<uint8_t> bytes;
  uint8_t nrc = 0;
  int waited_ms = 0;      ///< from the request to the end of the wait
  int pending_count = 0;  ///< 0x78 responses received
  std::string error;
};

class UdsClient {
 public:
  /// Opens the transport on `config.interface`. False with `error` naming the interface when the
  /// config is invalid or the interface is missing or down.
  bool Open(const IsoTpConfig& config, const ClientTiming& timing, std::string* error);

  /// Sends `request` (physically, or functionally: one single frame) and waits for its answer.
  /// `expect_response` false: a suppressed positive response; the call waits P2 for a negative
  /// one and returns kNoResponse when none came. Responses to earlier requests are dropped.
  UdsReply Request(const std::vector<uint8_t>& request, bool functional = false,
                   bool expect_response = true);

  /// Sends functional TesterPresent 0x3E 0x80 when tester_present_period_ms passed since the
  /// last request. Call while waiting between requests.
  void KeepAlive();

  /// "0x22 ReadDataByIdentifier on can0 (0x7E0 -> 0x7E8)": for error messages.
  std::string Describe(uint8_t sid) const;
  const ClientTiming& timing() const { return timing_; }

 private:
  UdsClientTransport transport_;
  IsoTpConfig config_;
  ClientTiming timing_;
  int64_t last_request_us_ = 0;
};

/// Monotonic clock, us.
int64_t MonotonicUs();

}  // namespace calibd::tester
