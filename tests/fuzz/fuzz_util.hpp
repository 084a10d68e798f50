#pragma once
// Shared by the fuzz targets: an invariant check that aborts under every build type (libFuzzer
// then keeps the input), a per-process temporary directory for the parsers that read only from
// a path, and the LCM decode exactly as the agent's bus does it.

#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "calibd/drivers/lcm_bus.hpp"

namespace calibd::fuzz {

/// Targets store what they read from a view here, so the reads are not optimised away and ASan
/// checks every element.
inline volatile double sink = 0.0;

/// Aborts with `what` when `ok` is false: an invariant of the parser under test is broken.
inline void Check(bool ok, const char* what) {
  if (ok) return;
  std::fprintf(stderr, "fuzz invariant broken: %s\n", what);
  std::abort();
}

/// One fresh directory per fuzzing process (under $TMPDIR or /tmp), removed at exit: the only
/// place a target writes.
inline const std::filesystem::path& ProcessTempDir() {
  static const std::filesystem::path dir = [] {
    const char* base = std::getenv("TMPDIR");
    std::string templ = std::string(base && *base ? base : "/tmp") + "/calibd-fuzz-XXXXXX";
    if (::mkdtemp(templ.data()) == nullptr) std::abort();
    std::atexit([] {
      std::error_code ec;
      std::filesystem::remove_all(ProcessTempDir(), ec);
    });
    return std::filesystem::path(templ);
  }();
  return dir;
}

/// Writes `size` bytes to `path` (replacing it).
inline void WriteBytes(const std::filesystem::path& path, const uint8_t* data, size_t size) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  Check(static_cast<bool>(out), "cannot write the temp file");
}

/// Decodes one LCM message as LcmBus does (lcm_bus.cpp): exactly one message of the type, and a
/// count asking for an absurd array (std::length_error, std::bad_alloc) is a malformed message.
template <typename Msg>
bool DecodeLikeTheBus(const uint8_t* data, size_t size, Msg* out) {
  if (size > static_cast<size_t>(INT32_MAX)) return false;
  bool delivered = false;
  lcm_bus_detail::TypedDecoder<Msg> decoder([&](const Msg& m, int64_t) {
    *out = m;
    delivered = true;
  });
  bool decoded = false;
  try {
    decoded = decoder.Decode(data, static_cast<int>(size));
  } catch (const std::exception&) {
    decoded = false;
  }
  if (decoded) decoder.Deliver(0);
  return decoded && delivered;
}

}  // namespace calibd::fuzz
