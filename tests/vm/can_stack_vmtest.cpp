// Inside the test VM: the kernel's CAN stack the drivers build on is there (raw and ISO-TP
// sockets bind to vcan0), and a host-built test binary runs in the guest (tests/vm/run_gtest.sh).

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/isotp.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <string>

#include "calibd/drivers/isotp_channel.hpp"

namespace {

int BindOnVcan0(int type, int protocol) {
  const int fd = ::socket(PF_CAN, type, protocol);
  if (fd < 0) return -1;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = static_cast<int>(if_nametoindex("vcan0"));
  addr.can_addr.tp.tx_id = 0x7E0;
  addr.can_addr.tp.rx_id = 0x7E8;
  if (addr.can_ifindex == 0 || ::bind(fd, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) != 0) {
    ::close(fd);
    return -1;
  }
  return fd;
}

TEST(CanStackVmTest, RawAndIsoTpSocketsBindToVcan0) {
  const int raw = BindOnVcan0(SOCK_RAW, CAN_RAW);
  EXPECT_GE(raw, 0) << "raw CAN socket on vcan0";
  const int isotp = BindOnVcan0(SOCK_DGRAM, CAN_ISOTP);
  EXPECT_GE(isotp, 0) << "ISO-TP socket on vcan0 (can-isotp module)";
  if (raw >= 0) ::close(raw);
  if (isotp >= 0) ::close(isotp);
}

// A kernel without the can-isotp module: the transport's error says what to load (the tester
// prints it and exits 7). The last test of this binary (GoogleTest runs them in file order): it
// unloads the module, and this guest ends with the run (the job's root has no copy of the guest
// kernel's modules to load it again).
TEST(CanStackVmTest, AMissingIsoTpModuleIsNamed) {
  ASSERT_EQ(std::system("rmmod can_isotp"), 0) << "rmmod can_isotp";
  calibd::IsoTpConfig config;
  config.interface = "vcan0";
  calibd::UdsClientTransport client;
  std::string error;
  const int64_t now_us = std::chrono::duration_cast<std::chrono::microseconds>(
                             std::chrono::steady_clock::now().time_since_epoch())
                             .count();
  client.Start(config, now_us, &error);
  const std::string said = error + " " + client.status().last_error;
  EXPECT_NE(said.find("ISO-TP module is not loaded (as root: modprobe can-isotp)"),
            std::string::npos)
      << said;
}

}  // namespace
