// The UDS server answers its periodic and polling requests without allocating (STYLE.md: fixed
// memory). Own file: it replaces the global operator new to count calls.

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <cstdlib>
#include <new>
#include <vector>

#include "calibd/agent/uds/uds_server.hpp"
#include "temp_dir.hpp"
#include "uds_fake_backend.hpp"

#include "counting_new.hpp"  // counts every operator new of the process

namespace calibd::uds {
namespace {

constexpr int64_t kS = 1000 * 1000;

TEST(UdsServerAllocationTest, RequestsAllocateNothing) {
  calibd::testing::TempDir dir;
  const UdsConfig config = calibd::testing::TestUdsConfig(dir.path().string());
  calibd::testing::FakeUdsBackend backend;
  backend.current = {true, 0.1, 0.2, 0.3, 1, 2, 3};
  UdsServer server(config, &backend);
  std::string error;
  ASSERT_TRUE(server.Init(0, 1'700'000'000LL * kS, &error)) << error;

  const std::vector<std::vector<uint8_t>> requests = {
      {0x10, 0x03},
      {0x3E, 0x00},
      {0x3E, 0x80},
      {0x22, 0xF1, 0x90, 0xF1, 0x8C, 0xF1, 0x95, 0xF1, 0x9B, 0xFD, 0x00,
       0xFD, 0x01, 0xFD, 0x02, 0xFD, 0x03, 0xFD, 0x04, 0xFD, 0x05},
      {0x19, 0x01, 0xFF},
      {0x19, 0x02, 0xFF},
      {0x19, 0x0A},
      {0x19, 0x04, 0x5A, 0x00, 0x54, 0xFF},
      {0x27, 0x01},                                // seed (getrandom)
      {0x31, 0x01, 0xF0, 0xA0, 0x00, 0x00, 0x3C},  // 0x33: locked
      {0x31, 0x03, 0xF0, 0xA0},                    // 0x24
      {0x2E, 0xF1, 0x90, 0x41},                    // 0x33
      {0x23, 0x00},                                // 0x11
      {0x10, 0x02},                                // 0x12
      {0x10, 0x01},
  };
  int64_t t = kS;
  for (int warm = 0; warm < 2; ++warm) {
    for (const auto& r : requests) server.Handle(r.data(), r.size(), false, t += 1000);
  }
  const long before = calibd::testing::Allocations();
  for (int cycle = 0; cycle < 100; ++cycle) {
    for (const auto& r : requests) {
      const Response response = server.Handle(r.data(), r.size(), cycle % 2 == 1, t += 1000);
      (void)response;
    }
    server.Tick(t += 6 * kS);
  }
  EXPECT_EQ(calibd::testing::Allocations() - before, 0);
}

}  // namespace
}  // namespace calibd::uds
