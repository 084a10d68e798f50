#include "calibd/agent/heap_reserve.hpp"

#include <malloc.h>
#include <sys/mman.h>
#include <unistd.h>

#include <chrono>
#include <climits>
#include <cstdint>
#include <cstdlib>
#include <vector>

#include "calibd/core/common/stopwatch.hpp"

namespace calibd {

namespace {

constexpr std::size_t kBlock = 8u << 20;  // below the mmap threshold
constexpr int kMmapThreshold = 32 << 20;  // glibc's maximum (64-bit)
#ifndef MADV_POPULATE_WRITE
constexpr int MADV_POPULATE_WRITE = 23;  // Linux 5.14 (uapi/asm-generic/mman-common.h)
#endif

// Allocates `bytes` from the calling thread's arena, populates and frees them.
std::size_t Populate(std::size_t bytes, bool* kernel) {
  const std::size_t page = static_cast<std::size_t>(sysconf(_SC_PAGESIZE));
  std::vector<void*> blocks;
  blocks.reserve(bytes / kBlock + 1);
  std::size_t reserved = 0;
  for (std::size_t done = 0; done < bytes; done += kBlock) {
    void* p = std::malloc(kBlock);
    if (p == nullptr) break;
    blocks.push_back(p);
    auto* first = reinterpret_cast<unsigned char*>(
        (reinterpret_cast<std::uintptr_t>(p) + page - 1) / page * page);
    auto* end = static_cast<unsigned char*>(p) + kBlock;
    const std::size_t span = static_cast<std::size_t>(end - first) / page * page;
    if (!*kernel || madvise(first, span, MADV_POPULATE_WRITE) != 0) {
      *kernel = false;
      for (auto* q = static_cast<volatile unsigned char*>(p); q < end; q += page) *q = 0;
    }
    reserved += kBlock;
  }
  for (void* p : blocks) std::free(p);
  return reserved;
}

}  // namespace

HeapReserveResult ReserveHeap(std::size_t bytes) {
  const auto t0 = std::chrono::steady_clock::now();
  HeapReserveResult r;
  // One arena: with one per thread (or two, tried), the solver's threads took arenas the
  // start-up thread never touched and faulted 4000 pages again.
  r.policy_set = mallopt(M_ARENA_MAX, 1) == 1;
  r.policy_set = (mallopt(M_TRIM_THRESHOLD, INT_MAX) == 1) && r.policy_set;
  r.policy_set = (mallopt(M_MMAP_THRESHOLD, kMmapThreshold) == 1) && r.policy_set;
  bool kernel = true;
  r.reserved = Populate(bytes, &kernel);
  r.populated_by_kernel = kernel && r.reserved > 0;
  r.ms = MsSince(t0);
  return r;
}

}  // namespace calibd
