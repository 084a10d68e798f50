#include "calibd/drivers/wake_event.hpp"

#include <sys/eventfd.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>

namespace calibd {

WakeEvent::~WakeEvent() {
  if (fd_ >= 0) ::close(fd_);
}

bool WakeEvent::Open(std::string* error) {
  if (fd_ >= 0) return true;
  fd_ = eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  if (fd_ < 0) {
    if (error) *error = std::string("eventfd: ") + std::strerror(errno);
    return false;
  }
  return true;
}

void WakeEvent::Signal() const {
  if (fd_ < 0) return;
  const uint64_t one = 1;
  // Fails only when the counter would overflow (EAGAIN): it is readable then anyway.
  (void)!::write(fd_, &one, sizeof(one));
}

void WakeEvent::Clear() const {
  if (fd_ < 0) return;
  uint64_t count = 0;
  (void)!::read(fd_, &count, sizeof(count));
}

}  // namespace calibd
