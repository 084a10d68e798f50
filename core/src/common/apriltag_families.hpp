#pragma once
// Private to core: libapriltag's families by name. The C types stay behind this header; public
// headers speak of families by their names only.

#include <apriltag/apriltag.h>

#include <string>

namespace calibd::internal {

struct AprilTagFamilyEntry {
  const char* name;
  apriltag_family_t* (*create)();
  void (*destroy)(apriltag_family_t*);
};

/// The entry for `name` (tag36h11, tag36h10, tag25h9, tag16h5, tagStandard41h12, tagCircle21h7,
/// tagCircle49h12, tagCustom48h12), or null.
const AprilTagFamilyEntry* FindAprilTagFamily(const std::string& name);

}  // namespace calibd::internal
