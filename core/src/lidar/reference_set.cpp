#include "calibd/core/lidar/reference_set.hpp"

namespace calibd {

void Fingerprint::Add(const void* data, size_t size) {
  const auto* bytes = static_cast<const unsigned char*>(data);
  for (size_t i = 0; i < size; ++i) {
    hash_ ^= bytes[i];
    hash_ *= 0x100000001b3ull;  // the 64-bit FNV prime
  }
}

void Fingerprint::Add(std::string_view text) {
  AddValue(text.size());
  Add(text.data(), text.size());
}

}  // namespace calibd
