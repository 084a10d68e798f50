#pragma once
// Test helper: replaces the global operator new/delete with versions that count every allocation
// of the process (all threads), for the "no allocation in steady state" tests. Include it in
// exactly one file of a test executable; read the count with calibd::testing::Allocations().

#include <atomic>
#include <cstdlib>
#include <new>

namespace calibd::testing {
inline std::atomic<long>& AllocationCount() {
  static std::atomic<long> count{0};
  return count;
}
inline long Allocations() { return AllocationCount().load(); }
}  // namespace calibd::testing

void* operator new(std::size_t size) {
  ++calibd::testing::AllocationCount();
  if (void* p = std::malloc(size == 0 ? 1 : size)) return p;
  throw std::bad_alloc();
}
// These replacements pair with each other, but GCC 12 (-O2, as in the asan preset) inlines the
// delete into gtest's `new TestClass` sites and warns of a new/free mismatch that is not there.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
void operator delete(void* p) noexcept { std::free(p); }
void operator delete(void* p, std::size_t) noexcept { std::free(p); }
#pragma GCC diagnostic pop
