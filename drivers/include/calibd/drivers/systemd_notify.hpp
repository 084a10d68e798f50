#pragma once
/// \file
/// The systemd service notification protocol (Type=notify units), over libsystemd's sd_notify(3)
/// and sd_watchdog_enabled(3) (https://www.freedesktop.org/software/systemd/man/sd_notify.html):
/// - READY=1 once start-up is finished: systemd holds the unit in "activating" until then, and
///   units ordered after it wait for it.
/// - STATUS=... a single-line, free-form state shown by `systemctl status`.
/// - STOPPING=1 when the service begins its shutdown.
/// - WATCHDOG=1 the keep-alive. With WatchdogSec= set, systemd passes WATCHDOG_USEC (and
///   WATCHDOG_PID, the process meant to ping); without a ping within that time it kills the
///   service (SIGABRT) and Restart= applies. sd_watchdog_enabled(3) recommends a ping every half
///   of the interval.
/// Each message is one datagram on the AF_UNIX socket named by NOTIFY_SOCKET (a path, or an
/// abstract name starting with '@'). With NOTIFY_SOCKET unset (run by hand, in tests) every call
/// is a no-op that costs one branch. The environment is read once, at construction, and left
/// set (unset_environment = 0): the agent starts no child that could inherit it.

#include <cstddef>
#include <cstdint>
#include <string_view>

namespace calibd {

class SystemdNotifier {
 public:
  /// Longest STATUS= text kept; longer text is cut (systemctl status shows one line anyway).
  static constexpr size_t kMaxStatusChars = 200;

  /// Reads NOTIFY_SOCKET, WATCHDOG_USEC and WATCHDOG_PID.
  SystemdNotifier();

  /// NOTIFY_SOCKET is set: messages are sent.
  bool enabled() const { return enabled_; }
  /// The watchdog timeout systemd expects pings within, us; 0 when no watchdog was asked for
  /// (WATCHDOG_USEC unset or invalid, WATCHDOG_PID naming another process, or NOTIFY_SOCKET
  /// unset: no ping could be sent). Ping every half of it.
  uint64_t watchdog_interval_us() const { return watchdog_interval_us_; }

  // Each returns true when the datagram was sent; false when disabled or the send failed (the
  // man page recommends ignoring the result: a daemon runs the same with or without a manager).
  bool Ready();
  bool Stopping();
  /// Allocation-free: the message is a constant.
  bool WatchdogPing();
  /// STATUS=`text`: cut at kMaxStatusChars, line breaks replaced by spaces (the protocol's
  /// assignments are newline-separated). Allocation-free: formatted in a member buffer.
  bool Status(std::string_view text);

 private:
  bool Send(const char* state);

  bool enabled_ = false;
  uint64_t watchdog_interval_us_ = 0;
  char status_[sizeof("STATUS=") + kMaxStatusChars] = {};
};

}  // namespace calibd
