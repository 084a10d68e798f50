#pragma once
// A small tmpfs mounted for one test, to make storage full (size=) or read-only (remount,ro) for
// real. Needs root (CAP_SYS_ADMIN); a test that cannot mount skips itself, loudly.

#include <gtest/gtest.h>
#include <sys/mount.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <filesystem>
#include <string>

namespace calibd::testing {

/// Mounts a tmpfs on `path` (created if missing) for the life of the object; unmounted (lazily)
/// on destruction, so declare it after the TempDir holding it.
class TmpfsMount {
 public:
  TmpfsMount(const std::string& path, const std::string& options) : path_(path) {
    std::filesystem::create_directories(path);
    if (::geteuid() != 0) {
      why_not_ = "not root";
    } else if (::mount("tmpfs", path.c_str(), "tmpfs", 0, options.c_str()) != 0) {
      why_not_ = "mount -t tmpfs -o " + options + " tmpfs " + path + ": " + std::strerror(errno);
    }
  }
  ~TmpfsMount() {
    if (why_not_.empty()) ::umount2(path_.c_str(), MNT_DETACH);
  }
  TmpfsMount(const TmpfsMount&) = delete;
  TmpfsMount& operator=(const TmpfsMount&) = delete;

  /// Empty when mounted, else why not.
  const std::string& why_not() const { return why_not_; }
  /// mount -o remount,ro (true) or remount,rw (false); false with errno set on failure.
  bool SetReadOnly(bool read_only) const {
    const unsigned long flags = static_cast<unsigned long>(MS_REMOUNT) |
                                (read_only ? static_cast<unsigned long>(MS_RDONLY) : 0UL);
    return ::mount("tmpfs", path_.c_str(), "tmpfs", flags, nullptr) == 0;
  }

 private:
  std::string path_;
  std::string why_not_;
};

}  // namespace calibd::testing

/// Skips the test, loudly, when `mount` (a TmpfsMount) could not be mounted (not root, or no
/// CAP_SYS_ADMIN in a container): the full or read-only storage case then went untested.
#define CALIBD_REQUIRE_TMPFS(mount)                                              \
  if (!(mount).why_not().empty())                                                \
  GTEST_SKIP() << "SKIPPED, NOT TESTED: this test needs a tmpfs mount and got '" \
               << (mount).why_not() << "'; run it as root"
