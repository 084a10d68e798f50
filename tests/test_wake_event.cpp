// WakeEvent on a real eventfd: a signal from another thread wakes poll(2) at once, Clear()
// consumes every signal so far, and nothing is readable before a signal.

#include "calibd/core/common/stopwatch.hpp"
#include "calibd/drivers/wake_event.hpp"

#include <gtest/gtest.h>
#include <poll.h>

#include <chrono>
#include <thread>

namespace calibd {
namespace {

bool Readable(const WakeEvent& e, int timeout_ms) {
  pollfd p{e.fd(), POLLIN, 0};
  return ::poll(&p, 1, timeout_ms) == 1 && (p.revents & POLLIN);
}

TEST(WakeEventTest, SignalFromAnotherThreadWakesPollAndClearResetsIt) {
  WakeEvent e;
  std::string error;
  ASSERT_TRUE(e.Open(&error)) << error;
  ASSERT_GE(e.fd(), 0);
  EXPECT_FALSE(Readable(e, 0));
  const auto t0 = std::chrono::steady_clock::now();
  std::thread t([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    e.Signal();
    e.Signal();
  });
  EXPECT_TRUE(Readable(e, 5000));
  const double waited_ms = MsSince(t0);
  t.join();
  EXPECT_GE(waited_ms, 15.0);    // woke by the signal, not before it
  EXPECT_LT(waited_ms, 2000.0);  // and not by the timeout
  e.Clear();                     // both signals consumed at once
  EXPECT_FALSE(Readable(e, 0));
  e.Signal();
  EXPECT_TRUE(Readable(e, 0));
}

TEST(WakeEventTest, UnopenedEventIgnoresSignalAndClear) {
  WakeEvent e;
  EXPECT_EQ(e.fd(), -1);
  e.Signal();
  e.Clear();
  std::string error;
  ASSERT_TRUE(e.Open(&error)) << error;
  EXPECT_FALSE(Readable(e, 0));
}

}  // namespace
}  // namespace calibd
