#pragma once
/// \file
/// Integer formatting for the agent's status texts, which are rebuilt while a session runs.

#include <charconv>
#include <cstdint>
#include <string>

namespace calibd {

/// Appends `v` in decimal without allocating while `s` has the capacity (std::to_string would
/// allocate).
inline void AppendInt(std::string* s, int64_t v) {
  char buf[24];
  const auto result = std::to_chars(buf, buf + sizeof(buf), v);
  s->append(buf, result.ptr);
}

}  // namespace calibd
