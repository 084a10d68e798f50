// One file of the on-vehicle calibration store (current.json, reference.json, history/v*.json)
// as CalibrationStore::Open reads it: ParseCalibrationFile on the file's text. What it accepts
// must pass StoredCalibration::IsValid.

#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/calibration_store.hpp"
#include "fuzz_util.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using calibd::fuzz::Check;
  const std::string text(reinterpret_cast<const char*>(data), size);
  calibd::StoredCalibration c;
  std::string error;
  if (!calibd::ParseCalibrationFile(text, &c, &error)) {
    Check(!error.empty(), "a refused file says why");
    return 0;
  }
  Check(c.IsValid(&error), "an accepted calibration is valid");
  Check(c.version >= 1 && c.replaced_version >= 0 && c.replaced_version < c.version,
        "versions in order");
  return 0;
}
