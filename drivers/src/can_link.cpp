#include "calibd/drivers/can_link.hpp"

#include <net/if.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <utility>

namespace calibd {

const char* ToString(CanLinkState state) {
  switch (state) {
    case CanLinkState::kClosed:
      return "closed";
    case CanLinkState::kUp:
      return "up";
    case CanLinkState::kDown:
      return "down";
    case CanLinkState::kNoInterface:
      return "no_interface";
    case CanLinkState::kBusOff:
      return "bus_off";
    case CanLinkState::kFailed:
      return "failed";
  }
  return "unknown";
}

bool CanReopenPolicy::IsValid(std::string* error) const {
  if (initial_ms == 0 || max_ms < initial_ms) {
    if (error)
      *error = "reopen backoff: initial_ms (" + std::to_string(initial_ms) +
               ") must be > 0 and <= max_ms (" + std::to_string(max_ms) + ")";
    return false;
  }
  return true;
}

int64_t ReopenDelayUs(const CanReopenPolicy& policy, int failed_tries) {
  int64_t delay_ms = policy.initial_ms;
  for (int i = 0; i < failed_tries && delay_ms < policy.max_ms; ++i) delay_ms *= 2;
  return std::min<int64_t>(delay_ms, policy.max_ms) * 1000;
}

void CanLinkSupervisor::Reset(const CanReopenPolicy& policy) {
  policy_ = policy;
  status_ = CanLinkStatus{};
  last_now_us_ = 0;
  next_try_us_ = 0;
  failed_tries_ = 0;
  first_try_ = true;
  schedule_pending_ = false;
}

bool CanLinkSupervisor::Due(int64_t now_us) {
  last_now_us_ = now_us;
  if (schedule_pending_) {
    // Lost() between two Ticks: the first retry counts from this Tick.
    schedule_pending_ = false;
    next_try_us_ = now_us + ReopenDelayUs(policy_, 0);
    return false;
  }
  // Bus-off keeps the socket: the controller recovers by itself (restart-ms) or by hand.
  const CanLinkState state = status_.state;
  return state != CanLinkState::kUp && state != CanLinkState::kClosed &&
         state != CanLinkState::kBusOff && now_us >= next_try_us_;
}

void CanLinkSupervisor::Opened() {
  if (!first_try_) {
    ++status_.counters.reopen_attempts;
    ++status_.counters.reopens;
  }
  first_try_ = false;
  status_.state = CanLinkState::kUp;
  failed_tries_ = 0;
}

void CanLinkSupervisor::OpenFailed(CanLinkState state, std::string error) {
  if (!first_try_) ++status_.counters.reopen_attempts;
  first_try_ = false;
  Schedule(state, std::move(error));
}

void CanLinkSupervisor::Lost(CanLinkState state, std::string error) {
  ++status_.counters.link_losses;
  failed_tries_ = 1;
  status_.state = state;
  status_.last_error = std::move(error);
  schedule_pending_ = true;
}

void CanLinkSupervisor::Schedule(CanLinkState state, std::string error) {
  status_.state = state;
  status_.last_error = std::move(error);
  next_try_us_ = last_now_us_ + ReopenDelayUs(policy_, failed_tries_);
  ++failed_tries_;
}

CanLinkState CheckCanInterface(const std::string& name, int* ifindex, int* mtu,
                               std::string* error) {
  const unsigned index = if_nametoindex(name.c_str());
  if (index == 0) {
    if (error) *error = "CAN interface " + name + ": if_nametoindex: " + std::strerror(errno);
    return CanLinkState::kNoInterface;
  }
  if (ifindex) *ifindex = static_cast<int>(index);
  // Any socket serves for the interface ioctls (they fall through to dev_ioctl); AF_UNIX needs
  // no CAN module.
  const int fd = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  if (fd < 0) {
    if (error) *error = std::string("socket(AF_UNIX) for SIOCGIFFLAGS: ") + std::strerror(errno);
    return CanLinkState::kFailed;
  }
  ifreq ifr{};
  std::strncpy(ifr.ifr_name, name.c_str(), IFNAMSIZ - 1);
  CanLinkState state = CanLinkState::kUp;
  if (::ioctl(fd, SIOCGIFFLAGS, &ifr) != 0) {
    if (error) *error = "CAN interface " + name + ": SIOCGIFFLAGS: " + std::strerror(errno);
    state = errno == ENODEV ? CanLinkState::kNoInterface : CanLinkState::kFailed;
  } else if ((ifr.ifr_flags & IFF_UP) == 0) {
    if (error) *error = "CAN interface " + name + " is down";
    state = CanLinkState::kDown;
  } else if (mtu) {
    if (::ioctl(fd, SIOCGIFMTU, &ifr) == 0) *mtu = ifr.ifr_mtu;
  }
  ::close(fd);
  return state;
}

std::string CanIdText(uint32_t id) {
  char text[16];
  std::snprintf(text, sizeof(text), "0x%X", static_cast<unsigned>(id));
  return text;
}

bool CanInterfaceNameValid(const std::string& name, std::string* error) {
  if (!name.empty() && name.size() < IFNAMSIZ) return true;
  if (error)
    *error =
        "interface: \"" + name + "\" must have 1-" + std::to_string(IFNAMSIZ - 1) + " characters";
  return false;
}

bool IsLinkErrno(int err) {
  return err == ENETDOWN || err == ENODEV || err == ENXIO || err == ENETUNREACH ||
         err == EADDRNOTAVAIL;
}

}  // namespace calibd
