#pragma once
/// \file
/// The reference descriptors a LidarDetector matches clusters against (paper §III-C-2), as a value
/// that outlives the detector: the agent keeps them between starts (drivers/lidar_reference_file),
/// since building them is most of its start-up work (hundreds of simulated board clusters, each
/// described several times) and they depend only on the config, the LiDAR model and the board
/// sizes, which `key` names.

#include <cstdint>
#include <string_view>
#include <vector>

namespace calibd {

struct LidarReferenceSet {
  /// LidarDetector::ReferenceKey() of what the descriptors were built from.
  uint64_t key = 0;
  int dims = 0;  ///< length of one descriptor
  /// The reference view (the index of the build's task: board size x DefaultReferenceViews())
  /// each descriptor describes, increasing; views whose board showed too few points are absent.
  std::vector<int32_t> views;
  std::vector<float> descriptors;  ///< dims values per entry of `views`, in its order
};

/// FNV-1a, 64 bits (Fowler, Noll, Vo): a fingerprint of bytes, for the key above. Written here
/// (ten lines) rather than taken from a library: it must give the same value on every platform
/// and in core, which links no hashing library. Not for security.
class Fingerprint {
 public:
  void Add(const void* data, size_t size);
  void Add(std::string_view text);
  template <typename T>
  void AddValue(const T& value) {
    Add(&value, sizeof(value));
  }
  uint64_t value() const { return hash_; }

 private:
  uint64_t hash_ = 0xcbf29ce484222325ull;
};

}  // namespace calibd
