#pragma once
/// \file
/// RAII writer for LCM log files (LCM's own log format, readable by the `file://` provider,
/// lcm-logplayer and lcm-spy). Event timestamps are the caller's (sensor capture times), so a log
/// replays at the pace the data was captured.

#include <cstdint>
#include <memory>
#include <string>

namespace calibd {

class LcmLogWriter {
 public:
  LcmLogWriter();
  ~LcmLogWriter();
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  /// Creates (truncates) `path`. Returns false with `error` naming the path and errno text.
  bool Open(const std::string& path, std::string* error);

  /// Appends one event. Returns false with `error` on a short write (e.g. disk full).
  bool Write(const std::string& channel, int64_t utime, const void* data, size_t size,
             std::string* error);

  /// Encodes an lcm-gen message and appends it. The encode buffer is reused between calls.
  template <typename Msg>
  bool WriteMessage(const std::string& channel, int64_t utime, const Msg& msg, std::string* error) {
    const int size = msg.getEncodedSize();
    if (static_cast<size_t>(size) > buffer_size_) Grow(static_cast<size_t>(size));
    if (msg.encode(buffer_.get(), 0, size) != size) {
      if (error) *error = "LCM encode failed on channel " + channel;
      return false;
    }
    return Write(channel, utime, buffer_.get(), static_cast<size_t>(size), error);
  }

  /// Flushes and closes; false with `error` if the final flush failed.
  bool Close(std::string* error);

  int64_t events_written() const { return events_; }

 private:
  void Grow(size_t size);
  struct Impl;
  std::unique_ptr<Impl> impl_;
  std::unique_ptr<uint8_t[]> buffer_;
  size_t buffer_size_ = 0;
  int64_t events_ = 0;
};

}  // namespace calibd
