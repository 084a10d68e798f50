#pragma once
/// \file
/// A private network namespace for live LCM runs (tests, benchmarks): the calling process, and
/// every process it starts afterwards, get a loopback of their own with a multicast route, so
/// LCM's UDP multicast (udpm) traffic cannot leave it. Needs root (CAP_SYS_ADMIN) and iproute2.

#include <string>

namespace calibd::sim {

/// LCM URL for the namespace: ttl=0 and a receive buffer large enough for a burst of full-size
/// frames (the kernel caps it at net.core.rmem_max, which EnterPrivateNetwork raises).
inline constexpr const char* kPrivateUdpmUrl =
    "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=16777216";
/// LCM fragments a 7.4 MB image into about 5.8k datagrams: with a 4 MB receive buffer whole
/// images are lost. net.core.rmem_max is not per namespace: this raises it for the host.
inline constexpr long kPrivateRmemMax = 33554432;

/// Raises net.core.rmem_max to kPrivateRmemMax if lower, moves the process into a new network
/// namespace and sets up multicast on its loopback. False with `error` saying what failed and
/// what it needs.
bool EnterPrivateNetwork(std::string* error);

}  // namespace calibd::sim
