#include "calibd/drivers/lcm_log.hpp"

#include <lcm/eventlog.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace calibd {

struct LcmLogWriter::Impl {
  lcm_eventlog_t* log = nullptr;
  std::string path;
};

LcmLogWriter::LcmLogWriter() = default;
LcmLogWriter::~LcmLogWriter() { Close(nullptr); }

bool LcmLogWriter::Open(const std::string& path, std::string* error) {
  Close(nullptr);
  lcm_eventlog_t* log = lcm_eventlog_create(path.c_str(), "w");
  if (!log) {
    if (error) *error = "cannot create LCM log '" + path + "': " + std::strerror(errno);
    return false;
  }
  impl_ = std::make_unique<Impl>();
  impl_->log = log;
  impl_->path = path;
  events_ = 0;
  return true;
}

bool LcmLogWriter::Write(const std::string& channel, int64_t utime, const void* data, size_t size,
                         std::string* error) {
  if (!impl_ || !impl_->log) {
    if (error) *error = "LCM log is not open";
    return false;
  }
  lcm_eventlog_event_t ev{};
  ev.eventnum = events_;
  ev.timestamp = utime;
  ev.channellen = static_cast<int32_t>(channel.size());
  ev.datalen = static_cast<int32_t>(size);
  ev.channel = const_cast<char*>(channel.c_str());  // the C API takes non-const but only reads
  ev.data = const_cast<void*>(data);
  if (lcm_eventlog_write_event(impl_->log, &ev) != 0) {
    if (error) *error = "write to LCM log '" + impl_->path + "' failed: " + std::strerror(errno);
    return false;
  }
  ++events_;
  return true;
}

bool LcmLogWriter::Close(std::string* error) {
  if (!impl_ || !impl_->log) return true;
  bool ok = std::fflush(impl_->log->f) == 0;
  if (!ok && error)
    *error = "flush of LCM log '" + impl_->path + "' failed: " + std::strerror(errno);
  lcm_eventlog_destroy(impl_->log);
  impl_.reset();
  return ok;
}

void LcmLogWriter::Grow(size_t size) {
  buffer_ = std::make_unique<uint8_t[]>(size);
  buffer_size_ = size;
}

}  // namespace calibd
