#include "private_network.hpp"

#include <sched.h>

#include <cerrno>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "calibd/core/common/validation.hpp"

namespace calibd::sim {

namespace {

constexpr const char* kRmemPath = "/proc/sys/net/core/rmem_max";

long ReadRmemMax() {
  std::ifstream f(kRmemPath);
  long v = 0;
  f >> v;
  return v;
}

}  // namespace

bool EnterPrivateNetwork(std::string* error) {
  if (ReadRmemMax() < kPrivateRmemMax) {
    std::ofstream f(kRmemPath);
    f << kPrivateRmemMax;
  }
  if (ReadRmemMax() < kPrivateRmemMax)
    return Invalid(error, "net.core.rmem_max is " + std::to_string(ReadRmemMax()) +
                              " and could not be raised (needs root: sysctl -w net.core.rmem_max=" +
                              std::to_string(kPrivateRmemMax) + ")");
  if (::unshare(CLONE_NEWNET) != 0)
    return Invalid(error, std::string("unshare(CLONE_NEWNET): ") + std::strerror(errno) +
                              " (a private network namespace needs root or CAP_SYS_ADMIN)");
  if (std::system("ip link set lo up && ip link set lo multicast on && "
                  "ip route add 224.0.0.0/4 dev lo") != 0)
    return Invalid(error, "could not set up multicast on the namespace's loopback (iproute2's ip)");
  return true;
}

}  // namespace calibd::sim
