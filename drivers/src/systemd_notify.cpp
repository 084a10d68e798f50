#include "calibd/drivers/systemd_notify.hpp"

#include <systemd/sd-daemon.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>

namespace calibd {

namespace {
constexpr char kStatusPrefix[] = "STATUS=";
}  // namespace

SystemdNotifier::SystemdNotifier() {
  const char* socket = std::getenv("NOTIFY_SOCKET");
  enabled_ = socket != nullptr && socket[0] != '\0';
  // sd_watchdog_enabled(3): > 0 and `usec` valid when WATCHDOG_USEC is set and WATCHDOG_PID is
  // unset or this process; 0 otherwise; < 0 when the variables cannot be parsed.
  uint64_t usec = 0;
  if (enabled_ && sd_watchdog_enabled(0, &usec) > 0) watchdog_interval_us_ = usec;
  std::memcpy(status_, kStatusPrefix, sizeof(kStatusPrefix));
}

bool SystemdNotifier::Send(const char* state) {
  // sd_notify(3): 0 when NOTIFY_SOCKET is unset, > 0 when sent, < 0 on error.
  return enabled_ && sd_notify(0, state) > 0;
}

bool SystemdNotifier::Ready() { return Send("READY=1"); }

bool SystemdNotifier::Stopping() { return Send("STOPPING=1"); }

bool SystemdNotifier::WatchdogPing() { return Send("WATCHDOG=1"); }

bool SystemdNotifier::Status(std::string_view text) {
  if (!enabled_) return false;
  const size_t n = std::min(text.size(), kMaxStatusChars);
  char* out = status_ + sizeof(kStatusPrefix) - 1;
  for (size_t i = 0; i < n; ++i) out[i] = text[i] == '\n' || text[i] == '\r' ? ' ' : text[i];
  out[n] = '\0';
  return Send(status_);
}

}  // namespace calibd
