#include "notify_socket.hpp"

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string_view>

namespace calibd::bench {

bool NotifySocket::Bind(const std::string& path, std::string* error) {
  Close();
  sockaddr_un addr{};
  if (path.size() >= sizeof(addr.sun_path)) {
    *error = "notify socket path too long: " + path;
    return false;
  }
  ::unlink(path.c_str());
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  addr.sun_family = AF_UNIX;
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  if (fd_ < 0 || ::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
    *error = "notify socket " + path + ": " + std::strerror(errno);
    return false;
  }
  path_ = path;
  return true;
}

bool NotifySocket::WaitReady(int timeout_ms) {
  using Clock = std::chrono::steady_clock;
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  char buf[4096];
  while (fd_ >= 0 && Clock::now() < deadline) {
    pollfd p{fd_, POLLIN, 0};
    const auto left =
        std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count();
    if (::poll(&p, 1, static_cast<int>(std::max<long long>(left, 0))) <= 0) continue;
    const ssize_t n = ::recv(fd_, buf, sizeof(buf), 0);
    if (n <= 0) continue;
    const std::string_view text(buf, static_cast<size_t>(n));
    if (text.substr(0, 8) == "READY=1\n" || text == "READY=1" ||
        text.find("\nREADY=1") != std::string_view::npos)
      return true;
  }
  return false;
}

void NotifySocket::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  if (!path_.empty()) ::unlink(path_.c_str());
  path_.clear();
}

}  // namespace calibd::bench
