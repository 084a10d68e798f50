#pragma once
/// \file
/// An eventfd(2) that worker threads signal and the poll loop waits on, owned (RAII). Signal()
/// may be called from any thread; Clear() from the thread that polls fd().

#include <string>

namespace calibd {

class WakeEvent {
 public:
  WakeEvent() = default;
  ~WakeEvent();
  WakeEvent(const WakeEvent&) = delete;
  WakeEvent& operator=(const WakeEvent&) = delete;

  /// Creates the eventfd (non-blocking, close-on-exec). False with `error` set when it fails.
  bool Open(std::string* error);
  /// Makes fd() readable until the next Clear(). No-op before Open().
  void Signal() const;
  /// Consumes all signals so far.
  void Clear() const;
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

}  // namespace calibd
