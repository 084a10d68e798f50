#pragma once
/// \file
/// The datagram socket systemd would give a Type=notify service (sd_notify(3)): the benches point
/// the agent's NOTIFY_SOCKET at one to time its start-up to READY=1, as systemd would see it.

#include <string>

namespace calibd::bench {

class NotifySocket {
 public:
  NotifySocket() = default;
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;
  ~NotifySocket() { Close(); }

  /// Binds at `path` (replacing a stale socket file); false with `error` naming the path.
  bool Bind(const std::string& path, std::string* error);
  /// Waits up to `timeout_ms` for a datagram with a READY=1 line; false on timeout.
  bool WaitReady(int timeout_ms);
  /// Closes the socket: the agent's later notifications fail (ECONNREFUSED) instead of filling a
  /// buffer nobody reads.
  void Close();

 private:
  int fd_ = -1;
  std::string path_;
};

}  // namespace calibd::bench
