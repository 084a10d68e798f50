#include "calibd/agent/session_marker.hpp"

#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <sstream>
#include <system_error>

#include "calibd/drivers/atomic_file.hpp"

namespace calibd {

namespace {

constexpr char kHeader[] = "calibd-session 1";
constexpr size_t kMaxTrigger = 64;
constexpr size_t kMaxFileBytes = 4096;  // a marker is ~80 bytes

// Keeps the file one field per line whatever a requester string holds.
std::string Printable(const std::string& s) {
  std::string out;
  for (const char ch : s.substr(0, kMaxTrigger)) out += (ch >= 0x20 && ch < 0x7f) ? ch : '_';
  return out.empty() ? "unknown" : out;
}

// "<key> <value>" -> value; false for another key.
bool Field(const std::string& line, const char* key, std::string* value) {
  const std::string prefix = std::string(key) + " ";
  if (line.rfind(prefix, 0) != 0 || line.size() == prefix.size()) return false;
  *value = line.substr(prefix.size());
  return true;
}

bool ParseInt(const std::string& text, int64_t* value) {
  if (text.empty() || text.size() > 18) return false;
  for (const char ch : text)
    if (ch < '0' || ch > '9') return false;
  *value = std::stoll(text);
  return true;
}

}  // namespace

std::string SessionMarkerPath(const std::string& store_directory) {
  return store_directory + "/session_in_progress";
}

bool WriteSessionMarker(const std::string& path, const SessionMarker& marker, std::string* error) {
  const std::string text = std::string(kHeader) + "\nsession " + std::to_string(marker.session) +
                           "\ntrigger " + Printable(marker.trigger) + "\nstarted_unix_s " +
                           std::to_string(marker.started_unix_s) + "\nend\n";
  return WriteFileAtomic(path, text, error);
}

MarkerRead ReadSessionMarker(const std::string& path, SessionMarker* marker, std::string* error) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) return MarkerRead::kNone;
  if (std::filesystem::file_size(path, ec) > kMaxFileBytes || ec) {
    *error = path + ": not a session marker (too large or unreadable)";
    return MarkerRead::kUnreadable;
  }
  std::string text;
  if (!ReadWholeFile(path, &text, error)) return MarkerRead::kUnreadable;
  std::istringstream in(text);
  std::string header, session, trigger, started, end;
  int64_t session_number = 0;
  SessionMarker m;
  const bool ok = std::getline(in, header) && header == kHeader && std::getline(in, session) &&
                  Field(session, "session", &session) && ParseInt(session, &session_number) &&
                  session_number >= 1 && session_number <= INT32_MAX && std::getline(in, trigger) &&
                  Field(trigger, "trigger", &m.trigger) && std::getline(in, started) &&
                  Field(started, "started_unix_s", &started) &&
                  ParseInt(started, &m.started_unix_s) && std::getline(in, end) && end == "end";
  if (!ok) {
    *error = path + ": damaged session marker";
    return MarkerRead::kUnreadable;
  }
  m.session = static_cast<int>(session_number);
  *marker = m;
  return MarkerRead::kFound;
}

bool RemoveSessionMarker(const std::string& path, std::string* error) {
  // WriteFileAtomic's temp files are "<target>.tmp.<pid>": one is left by a write interrupted by
  // a kill; it never replaced the marker, so it goes too.
  const std::filesystem::path target(path);
  const std::string temp_prefix = target.filename().string() + ".tmp.";
  std::error_code ec;
  for (std::filesystem::directory_iterator it(target.parent_path(), ec), end; !ec && it != end;
       it.increment(ec))
    if (it->path().filename().string().rfind(temp_prefix, 0) == 0) ::unlink(it->path().c_str());
  if (::unlink(path.c_str()) != 0 && errno != ENOENT) {
    *error = "cannot remove '" + path + "': " + std::strerror(errno);
    return false;
  }
  return true;
}

std::string SessionMarkerFile::TakeInterrupted(std::string* error) {
  SessionMarker marker;
  std::string why;
  const MarkerRead read = ReadSessionMarker(path_, &marker, &why);
  if (read == MarkerRead::kNone) {
    std::string ignored;
    RemoveSessionMarker(path_, &ignored);  // a temp file of a write cut short, if any
    return {};
  }
  std::string line;
  if (read == MarkerRead::kFound) {
    char started[32] = "an unknown time";
    const time_t t = static_cast<time_t>(marker.started_unix_s);
    tm utc{};
    if (gmtime_r(&t, &utc) != nullptr) std::strftime(started, sizeof(started), "%FT%TZ", &utc);
    line = "the previous run stopped during session " + std::to_string(marker.session) +
           " (started by '" + marker.trigger + "' at " + started + ")";
  } else {
    line = "the previous run stopped during a session (" + why + ")";
  }
  line += " without a result: aborted; the stored calibration is unchanged";
  RemoveSessionMarker(path_, error);
  return line;
}

bool SessionMarkerFile::Begin(const SessionMarker& marker, std::string* error) {
  if (!WriteSessionMarker(path_, marker, error)) return false;
  session_ = marker.session;
  return true;
}

bool SessionMarkerFile::End(std::string* error) {
  if (session_ == 0) return true;
  session_ = 0;
  return RemoveSessionMarker(path_, error);
}

}  // namespace calibd
