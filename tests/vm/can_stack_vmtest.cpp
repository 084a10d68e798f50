// Inside the test VM: the kernel's CAN stack the drivers build on is there (raw and ISO-TP
// sockets bind to vcan0), and a host-built test binary runs in the guest (tests/vm/run_gtest.sh).

#include <gtest/gtest.h>
#include <linux/can.h>
#include <linux/can/isotp.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

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

}  // namespace
