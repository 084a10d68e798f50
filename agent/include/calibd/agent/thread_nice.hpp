#pragma once
/// \file
/// The agent's background threads at a lower priority than its poll loop: on a small CPU the poll
/// loop, which answers diagnostics within P2 (ISO 14229-2) and sends the cyclic status frame, takes
/// the CPU from detection and the solve whenever it wakes.

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

namespace calibd {

/// Frame detection and the session's solve (and the solver's helpers, which inherit it).
inline constexpr int kBackgroundNice = 5;
/// The LiDAR detector's reference descriptors, built once at start-up.
inline constexpr int kReferenceBuildNice = 10;

/// Sets the calling thread's nice value (Linux keeps one per thread; threads it starts inherit it).
/// Lowering needs no privilege; false where it is refused (a sandbox), the thread then keeping
/// the process's priority.
inline bool NiceThisThread(int nice) {
  return setpriority(PRIO_PROCESS, static_cast<id_t>(syscall(SYS_gettid)), nice) == 0;
}

}  // namespace calibd
