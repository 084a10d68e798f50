#include "calibd/agent/uds/dtc_store.hpp"

#include <cstdio>
#include <sstream>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd::uds {
namespace {

constexpr char kHeader[] = "calibd-dtc 1";

/// Parses the file's contents into `status`; false when it is not what Save writes (or wrote
/// before a DTC was added: that DTC has no line).
bool Parse(const std::string& contents, std::array<uint8_t, kDtcCount>* status) {
  std::istringstream in(contents);
  std::string line;
  if (!std::getline(in, line) || line != kHeader) return false;
  std::array<bool, kDtcCount> seen{};
  status->fill(kDtcStatusAfterClear);  // DTCs added after the file was written start cleared
  while (std::getline(in, line)) {
    if (line == "end") return true;
    unsigned number = 0, value = 0;
    char extra = 0;
    if (std::sscanf(line.c_str(), "%6x %2x%c", &number, &value, &extra) != 2) return false;
    const int index = DtcStore::IndexOf(number);
    if (index < 0 || (value & ~kDtcStatusAvailabilityMask) != 0) return false;
    if (seen[static_cast<size_t>(index)]) return false;  // twice: not what Save writes
    (*status)[static_cast<size_t>(index)] = static_cast<uint8_t>(value);
    seen[static_cast<size_t>(index)] = true;
  }
  return false;  // no "end": truncated
}

}  // namespace

int DtcStore::IndexOf(uint32_t number) {
  for (size_t i = 0; i < kDtcCount; ++i) {
    if (kDtcNumbers[i] == number) return static_cast<int>(i);
  }
  return -1;
}

void DtcStore::Open(const std::string& state_dir) {
  path_ = state_dir + "/dtc_status";
  warning_.clear();
  status_.fill(kDtcStatusAfterClear);
  std::string contents, error;
  if (ReadWholeFile(path_, &contents, &error)) {
    std::array<uint8_t, kDtcCount> loaded{};
    if (Parse(contents, &loaded)) {
      status_ = loaded;
    } else {
      warning_ = path_ + ": corrupt, every DTC starts cleared";
    }
  }
  NewOperationCycle();
}

void DtcStore::NewOperationCycle() {
  for (uint8_t& s : status_) {
    // Annex D.2 bit 2: pendingDTC clears after a cycle that completed the test without failing.
    const bool completed = (s & kTestNotCompletedThisOperationCycle) == 0;
    const bool failed = (s & kTestFailedThisOperationCycle) != 0;
    if (completed && !failed) s = static_cast<uint8_t>(s & ~kPendingDtc);
    s = static_cast<uint8_t>((s & ~kTestFailedThisOperationCycle) |
                             kTestNotCompletedThisOperationCycle);
  }
}

bool DtcStore::Report(Dtc dtc, bool failed, std::string* error) {
  if (!enabled_) return true;  // ISO 14229-1 §9.9: DTC setting off freezes the status bits
  uint8_t& s = status_[static_cast<size_t>(dtc)];
  uint8_t next = static_cast<uint8_t>(
      s & ~(kTestNotCompletedSinceLastClear | kTestNotCompletedThisOperationCycle));
  if (failed) {
    next |= kTestFailed | kTestFailedThisOperationCycle | kPendingDtc | kConfirmedDtc |
            kTestFailedSinceLastClear;
  } else {
    next = static_cast<uint8_t>(next & ~kTestFailed);
  }
  if (next == s) return true;
  s = next;
  return Save(error);
}

bool DtcStore::ClearAll(std::string* error) {
  status_.fill(kDtcStatusAfterClear);
  return Save(error);
}

bool DtcStore::Save(std::string* error) const {
  std::string contents = std::string(kHeader) + "\n";
  char line[16];
  for (size_t i = 0; i < kDtcCount; ++i) {
    std::snprintf(line, sizeof(line), "%06X %02X\n", static_cast<unsigned>(kDtcNumbers[i]),
                  static_cast<unsigned>(status_[i]));
    contents += line;
  }
  contents += "end\n";
  return WriteFileAtomic(path_, contents, error);
}

}  // namespace calibd::uds
