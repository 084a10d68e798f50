// Host-side parts of the CAN transports (drivers/can_link, isotp_channel, can_raw_socket) that
// need no AF_CAN: config validation, the reopen schedule and error-frame decoding. The socket
// behaviour is tested on real vcan in the VM (tests/vm/can_transport_vmtest.cpp).

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/error.h>

#include <string>

#include "calibd/drivers/can_link.hpp"
#include "calibd/drivers/can_raw_socket.hpp"
#include "calibd/drivers/isotp_channel.hpp"

namespace calibd {
namespace {

TEST(IsoTpConfigTest, DefaultsAreValidAndDocumented) {
  const IsoTpConfig config;
  std::string error;
  EXPECT_TRUE(config.IsValid(&error)) << error;
  EXPECT_EQ(config.interface, "can0");
  EXPECT_EQ(config.physical_request_id, 0x7E0u);
  EXPECT_EQ(config.physical_response_id, 0x7E8u);
  EXPECT_EQ(config.functional_request_id, 0x7DFu);
  EXPECT_FALSE(config.extended_ids);
  EXPECT_TRUE(config.padding);
  EXPECT_EQ(config.pad_byte, 0xCC);
  EXPECT_EQ(config.block_size, 0);
  EXPECT_EQ(config.st_min, 0);
  EXPECT_FALSE(config.can_fd);
  EXPECT_EQ(kIsoTpMaxMessage, 4095u);
}

TEST(IsoTpConfigTest, RejectsBadFieldsNamingThem) {
  struct Case {
    void (*mutate)(IsoTpConfig&);
    const char* key;
  } cases[] = {
      {[](IsoTpConfig& c) { c.interface = ""; }, "interface"},
      {[](IsoTpConfig& c) { c.interface = "a_very_long_ifname0"; }, "interface"},
      {[](IsoTpConfig& c) { c.physical_request_id = 0x800; }, "physical_request_id"},
      {[](IsoTpConfig& c) { c.physical_response_id = 0x18DAF110; }, "physical_response_id"},
      {[](IsoTpConfig& c) { c.functional_request_id = 0x7E8; }, "must differ"},
      {[](IsoTpConfig& c) { c.physical_request_id = 0x7E8; }, "must differ"},
      {[](IsoTpConfig& c) { c.st_min = 0x80; }, "st_min"},
      {[](IsoTpConfig& c) { c.st_min = 0xFA; }, "st_min"},
      {[](IsoTpConfig& c) {
         c.can_fd = true;
         c.fd_tx_dl = 40;
       },
       "fd_tx_dl"},
      {[](IsoTpConfig& c) { c.reopen.initial_ms = 0; }, "initial_ms"},
      {[](IsoTpConfig& c) { c.reopen.max_ms = 50; }, "initial_ms"},
  };
  for (const Case& c : cases) {
    IsoTpConfig config;
    c.mutate(config);
    std::string error;
    EXPECT_FALSE(config.IsValid(&error)) << c.key;
    EXPECT_NE(error.find(c.key), std::string::npos) << error;
  }
  IsoTpConfig extended;
  extended.extended_ids = true;
  extended.physical_request_id = 0x18DA10F1;
  extended.physical_response_id = 0x18DAF110;
  extended.functional_request_id = 0x18DB33F1;
  extended.st_min = 0xF5;  // 500 us
  extended.can_fd = true;
  extended.fd_tx_dl = 32;
  std::string error;
  EXPECT_TRUE(extended.IsValid(&error)) << error;
  extended.physical_request_id = 0x20000000;
  EXPECT_FALSE(extended.IsValid(&error));
  EXPECT_NE(error.find("29 bits"), std::string::npos) << error;
}

TEST(CanRawConfigTest, Validation) {
  CanRawConfig config;
  std::string error;
  EXPECT_TRUE(config.IsValid(&error)) << error;
  EXPECT_TRUE(config.error_frames);
  config.num_filters = CanRawConfig::kMaxFilters + 1;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("num_filters"), std::string::npos);
  config.num_filters = 1;
  config.filters[0] = {0x900, 0x7FF, false};
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("filters[0]"), std::string::npos);
  config.filters[0].extended = true;
  EXPECT_TRUE(config.IsValid(&error)) << error;
}

TEST(CanReopenTest, BackoffDoublesFrom100MsTo5s) {
  const CanReopenPolicy policy;
  const int64_t expected_ms[] = {100, 200, 400, 800, 1600, 3200, 5000, 5000, 5000};
  for (int i = 0; i < 9; ++i) EXPECT_EQ(ReopenDelayUs(policy, i), expected_ms[i] * 1000) << i;
  EXPECT_EQ(ReopenDelayUs(policy, 1000), 5000000);  // no overflow
}

TEST(CanReopenTest, SupervisorSchedulesTriesAndCounts) {
  CanLinkSupervisor link;
  link.Reset(CanReopenPolicy{});
  EXPECT_EQ(link.status().state, CanLinkState::kClosed);
  EXPECT_FALSE(link.Due(0));
  link.OpenFailed(CanLinkState::kNoInterface, "no can0");  // first try at start: not a reopen
  EXPECT_EQ(link.status().counters.reopen_attempts, 0);
  EXPECT_FALSE(link.Due(99999));
  EXPECT_TRUE(link.Due(100000));
  link.OpenFailed(CanLinkState::kDown, "can0 is down");
  EXPECT_FALSE(link.Due(299999));  // 100 + 200 ms
  EXPECT_TRUE(link.Due(300000));
  link.Opened();
  EXPECT_TRUE(link.up());
  EXPECT_EQ(link.status().counters.reopen_attempts, 2);
  EXPECT_EQ(link.status().counters.reopens, 1);
  EXPECT_FALSE(link.Due(10000000));

  // Lost between Ticks: the first retry is initial_ms after the next Tick.
  link.Lost(CanLinkState::kDown, "recv: Network is down");
  EXPECT_EQ(link.status().counters.link_losses, 1);
  EXPECT_EQ(link.status().last_error, "recv: Network is down");
  EXPECT_FALSE(link.Due(20000000));
  EXPECT_FALSE(link.Due(20099999));
  EXPECT_TRUE(link.Due(20100000));
  link.OpenFailed(CanLinkState::kDown, "down");
  EXPECT_FALSE(link.Due(20299999));
  EXPECT_TRUE(link.Due(20300000));
  link.OpenFailed(CanLinkState::kDown, "down");
  EXPECT_TRUE(link.Due(20700000));

  // Bus-off keeps the socket: no tries.
  link.Opened();
  link.SetState(CanLinkState::kBusOff);
  EXPECT_FALSE(link.Due(99000000));
}

TEST(CanErrorFrameTest, DecodesBusOffControllerAndCounters) {
  std::array<uint8_t, 8> data{};
  CanErrorFrame e = DecodeCanErrorFrame(CAN_ERR_FLAG | CAN_ERR_BUSOFF, data);
  EXPECT_TRUE(e.bus_off);
  EXPECT_FALSE(e.restarted);
  EXPECT_FALSE(e.has_counters);
  EXPECT_EQ(Describe(e), "bus-off");

  data[1] = CAN_ERR_CRTL_TX_PASSIVE;
  data[6] = 128;
  data[7] = 3;
  e = DecodeCanErrorFrame(CAN_ERR_FLAG | CAN_ERR_CRTL | CAN_ERR_CNT, data);
  EXPECT_TRUE(e.controller);
  EXPECT_TRUE(e.error_passive);
  EXPECT_FALSE(e.error_warning);
  EXPECT_FALSE(e.bus_off);
  ASSERT_TRUE(e.has_counters);
  EXPECT_EQ(e.tx_error_count, 128);
  EXPECT_EQ(e.rx_error_count, 3);
  EXPECT_EQ(Describe(e), "error passive (tx errors 128, rx errors 3)");

  data = {};
  data[1] = CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_RX_WARNING;
  e = DecodeCanErrorFrame(CAN_ERR_CRTL | CAN_ERR_RESTARTED | CAN_ERR_ACK, data);
  EXPECT_TRUE(e.restarted);
  EXPECT_TRUE(e.no_ack);
  EXPECT_TRUE(e.rx_overflow);
  EXPECT_TRUE(e.error_warning);
  EXPECT_EQ(Describe(e), "restarted, no ack, error warning, rx overflow");
}

TEST(CanLinkTest, MissingInterfaceIsReportedNotFatal) {
  int ifindex = -1;
  std::string error;
  EXPECT_EQ(CheckCanInterface("nocan9", &ifindex, nullptr, &error), CanLinkState::kNoInterface);
  EXPECT_NE(error.find("nocan9"), std::string::npos);
  EXPECT_EQ(CheckCanInterface("lo", &ifindex, nullptr, &error), CanLinkState::kUp);
  EXPECT_GT(ifindex, 0);

  // A server on a missing interface starts (the config is fine) and retries.
  UdsServerTransport server;
  IsoTpConfig config;
  config.interface = "nocan9";
  ASSERT_TRUE(server.Start(config, 0, &error)) << error;
  EXPECT_EQ(server.status().state, CanLinkState::kNoInterface);
  EXPECT_EQ(server.physical_fd(), -1);
  const uint8_t byte = 0x3E;
  EXPECT_EQ(server.Send(&byte, 1), IsoTpIo::kLinkDown);
  server.Tick(100000);
  EXPECT_EQ(server.status().counters.reopen_attempts, 1);
  config.st_min = 0x90;
  EXPECT_FALSE(server.Start(config, 0, &error));
}

}  // namespace
}  // namespace calibd
