// The UDS server's request handler (ISO 14229-1 over ISO-TP: UdsServer::Handle), fed a sequence
// of requests so that sessions, security access and routines are reached, with the fake backend
// of the UDS suites. Input: records of [flags][length][length bytes]; flags bit 0: functionally
// addressed, bits 1-7: time elapsed before the request in 100 ms steps (S3 and lockout timers).
// Length 0xFF sends the right SecurityAccess key for the last seed instead (the fuzzer cannot
// compute an HMAC), so the services that need an unlocked ECU are reached too.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "calibd/agent/uds/security_access.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "fuzz_util.hpp"
#include "uds_fake_backend.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  namespace uds = calibd::uds;
  static const uds::UdsConfig config =
      calibd::testing::TestUdsConfig(calibd::fuzz::ProcessTempDir().string());
  // The state files (DTC status, lockout) of the previous input would make runs irreproducible.
  std::error_code ec;
  std::filesystem::remove(config.state_dir + "/dtc_status", ec);
  std::filesystem::remove(config.state_dir + "/security_lockout", ec);
  calibd::testing::FakeUdsBackend backend;
  uds::UdsServer server(config, &backend);
  std::string error;
  int64_t now_us = 100LL * 1000 * 1000;
  Check(server.Init(now_us, 1'700'000'000LL * 1000000, &error), "server starts");
  uint8_t seed[uds::kSeedSize] = {};
  bool have_seed = false;
  size_t pos = 0;
  while (pos + 2 <= size) {
    const uint8_t flags = data[pos];
    const size_t length = data[pos + 1];
    pos += 2;
    now_us += static_cast<int64_t>(flags >> 1) * 100000;
    server.Tick(now_us);
    uint8_t key_request[2 + uds::kKeySize] = {0x27, 0x02};
    const uint8_t* request = data + pos;
    size_t request_size = 0;
    if (length == 0xFF) {
      if (!have_seed) continue;
      Check(uds::ComputeKey(calibd::testing::kTestSecret, seed, sizeof(seed), key_request + 2),
            "HMAC");
      request = key_request;
      request_size = sizeof(key_request);
    } else {
      request_size = std::min(length, size - pos);
      pos += request_size;
    }
    const uds::Response r = server.Handle(request, request_size, (flags & 1) != 0, now_us);
    if (r.empty()) continue;
    Check(r.data != nullptr, "a response has bytes");
    if (r.data[0] == 0x7F) {
      Check(r.size == 3, "a negative response is 3 bytes");
      Check(request_size > 0 && r.data[1] == request[0], "a negative response names the SID");
    } else {
      Check(request_size > 0 && r.data[0] == static_cast<uint8_t>(request[0] + 0x40),
            "a positive response is SID + 0x40");
    }
    if (request_size == 2 && request[0] == 0x27 && request[1] == 0x01 &&
        r.size == 2 + uds::kSeedSize && r.data[0] == 0x67) {
      std::copy(r.data + 2, r.data + r.size, seed);
      have_seed = true;
    }
  }
  return 0;
}
