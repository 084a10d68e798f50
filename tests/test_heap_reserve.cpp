// The daemon's start-up heap policy (agent/heap_reserve.hpp), in child processes since mallopt
// is process-wide: after ReserveHeap, the solve's kind of allocation (an 11 MB dense Jacobian,
// made on another thread, as the solve thread does) takes almost no page faults; without it, one
// per 4 KiB page.

#include "calibd/agent/heap_reserve.hpp"

#include <gtest/gtest.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <thread>

namespace calibd {
namespace {

#if defined(__SANITIZE_ADDRESS__)
constexpr bool kSanitizer = true;
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
constexpr bool kSanitizer = true;
#else
constexpr bool kSanitizer = false;
#endif
#else
constexpr bool kSanitizer = false;
#endif

constexpr std::size_t kJacobianBytes = 11u << 20;

// Page faults of a thread that allocates and writes kJacobianBytes, in a child process that
// reserved `reserve` bytes first (0: none). Returns -1 when the child failed.
long FaultsOfASolveLikeAllocation(std::size_t reserve) {
  int pipe_fds[2];
  if (::pipe(pipe_fds) != 0) return -1;
  const pid_t pid = ::fork();
  if (pid == 0) {
    ::close(pipe_fds[0]);
    long faults = -1;
    bool ok = true;
    if (reserve > 0) {
      const HeapReserveResult r = ReserveHeap(reserve);
      ok = r.policy_set && r.reserved >= reserve;
    }
    std::thread t([&] {
      rusage a{}, b{};
      getrusage(RUSAGE_THREAD, &a);
      auto* p = static_cast<char*>(std::malloc(kJacobianBytes));
      if (p != nullptr) std::memset(p, 1, kJacobianBytes);
      asm volatile("" : : "r"(p) : "memory");  // the writes must happen (no elision of the pair)
      getrusage(RUSAGE_THREAD, &b);
      if (p != nullptr) faults = b.ru_minflt - a.ru_minflt;
      std::free(p);
    });
    t.join();
    if (!ok) faults = -2;
    (void)!::write(pipe_fds[1], &faults, sizeof(faults));
    ::_exit(0);
  }
  ::close(pipe_fds[1]);
  long faults = -1;
  if (::read(pipe_fds[0], &faults, sizeof(faults)) != sizeof(faults)) faults = -1;
  ::close(pipe_fds[0]);
  int status = 0;
  ::waitpid(pid, &status, 0);
  return faults;
}

TEST(HeapReserveTest, ReservedHeapServesALargeAllocationOnAnotherThreadWithoutFaults) {
  if (kSanitizer) GTEST_SKIP() << "the sanitizer replaces glibc malloc: mallopt has no effect";
  const long without = FaultsOfASolveLikeAllocation(0);
  const long with = FaultsOfASolveLikeAllocation(32u << 20);
  ASSERT_GE(without, 0);
  ASSERT_NE(with, -2) << "ReserveHeap did not set its policy or reserve the bytes";
  ASSERT_GE(with, 0);
  std::printf("page faults writing 11 MB on a new thread: %ld without the reserve, %ld with\n",
              without, with);
  EXPECT_GT(without, static_cast<long>(kJacobianBytes / 4096 / 2));  // one per page, about
  EXPECT_LT(with, 64);
}

TEST(HeapReserveTest, ZeroBytesOnlySetsThePolicy) {
  if (kSanitizer) GTEST_SKIP() << "the sanitizer replaces glibc malloc: mallopt has no effect";
  const pid_t pid = ::fork();
  if (pid == 0) {
    const HeapReserveResult r = ReserveHeap(0);
    ::_exit(r.policy_set && r.reserved == 0 ? 0 : 1);
  }
  int status = 0;
  ::waitpid(pid, &status, 0);
  EXPECT_TRUE(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

}  // namespace
}  // namespace calibd
