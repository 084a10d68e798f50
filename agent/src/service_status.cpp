#include "calibd/agent/service_status.hpp"

#include <cstdio>
#include <string>

namespace calibd {

const char* ServiceStatus::Changed(const SessionMachine& machine) {
  const SessionState s = machine.state();
  const int percent =
      s == SessionState::kCollecting ? static_cast<int>(machine.progress() * 10.0) * 10 : 0;
  if (static_cast<int>(s) == state_ && machine.session() == session_ && percent == percent_)
    return nullptr;
  state_ = static_cast<int>(s);
  session_ = machine.session();
  percent_ = percent;
  const std::string reason(NameOf(machine.reason()));
  const char* open = reason.empty() ? "" : " (";
  const char* close = reason.empty() ? "" : ")";
  if (s == SessionState::kIdle)
    std::snprintf(text_, sizeof(text_), "idle");
  else if (s == SessionState::kCollecting)
    std::snprintf(text_, sizeof(text_), "session %d: collecting %d%%", machine.session(), percent);
  else if (s == SessionState::kDone)
    std::snprintf(text_, sizeof(text_), "session %d: done, %s%s%s%s", machine.session(),
                  VerdictName(machine.verdict()), open, reason.c_str(), close);
  else
    std::snprintf(text_, sizeof(text_), "session %d: %s%s%s%s", machine.session(),
                  SessionStateName(s), open, reason.c_str(), close);
  return text_;
}

}  // namespace calibd
