#pragma once
// Test helper: runs a shell command (the project's own programs, end to end) and returns its exit
// code, or -1 when it did not exit normally (killed by a signal).

#include <sys/wait.h>

#include <cstdlib>
#include <string>

namespace calibd::testing {

inline int RunCommand(const std::string& command) {
  const int status = std::system(command.c_str());
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace calibd::testing
