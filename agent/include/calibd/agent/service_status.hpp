#pragma once
/// \file
/// The agent's STATUS= line for systemd (sd_notify(3)): "idle", "session 2: collecting 40%",
/// "session 2: done, updated", "session 3: failed (lidar_timeout)", ... Sent when the state, the
/// session or the collection progress (in 10 % steps) changed, not at every tick.

#include "calibd/agent/session_machine.hpp"
#include "calibd/drivers/systemd_notify.hpp"

namespace calibd {

class ServiceStatus {
 public:
  /// The line for `machine` when it differs from the last one returned, else null.
  const char* Changed(const SessionMachine& machine);

 private:
  int state_ = -1, session_ = -1, percent_ = -1;
  char text_[SystemdNotifier::kMaxStatusChars + 1] = {};
};

}  // namespace calibd
