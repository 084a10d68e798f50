#pragma once
/// \file
/// Start-up heap policy of the daemon: the solve's scratch memory (Ceres' Jacobians and
/// workspaces, a few tens of MB) is faulted in once at start-up and never handed back, so the
/// solve after the last frame does not pay a page fault per 4 KiB page (measured on the CI VM:
/// 19 us per touched page, 1.4 us per page when the kernel populates a range at once, and about
/// 7000 faults in a 200-pair solve).
///
/// glibc malloc is set up as a real-time daemon's heap usually is (mallopt(3)): one arena shared
/// by all threads, so memory freed by the start-up thread serves the solver's threads; no trim
/// of the top of the heap; no mmap for blocks below 32 MiB (the largest threshold glibc takes),
/// so large blocks come from the reserved heap too. Then `bytes` are allocated in 8 MiB blocks,
/// populated (madvise MADV_POPULATE_WRITE, or touched page by page on kernels before 5.14) and
/// freed back to the heap.

#include <cstddef>

namespace calibd {

struct HeapReserveResult {
  bool policy_set = false;           ///< all mallopt calls accepted
  std::size_t reserved = 0;          ///< bytes populated and left in the heap
  double ms = 0.0;                   ///< time taken
  bool populated_by_kernel = false;  ///< MADV_POPULATE_WRITE worked (else touched)
};

HeapReserveResult ReserveHeap(std::size_t bytes);

}  // namespace calibd
