#include "command_line.hpp"

#include <cstdlib>

#include "calibd/drivers/config_file.hpp"

namespace calibd::tools {

bool CommandLine::Next() {
  if (failed() || next_ >= argc_) return false;
  arg_ = argv_[next_++];
  return true;
}

bool CommandLine::Value(std::string* value) {
  if (next_ >= argc_) {
    error_ = "option " + arg_ + " needs a value (see --help)";
    return false;
  }
  *value = argv_[next_++];
  return true;
}

bool CommandLine::OnOff(bool* value) {
  std::string text;
  if (!Value(&text)) return false;
  if (text != "on" && text != "off") {
    error_ = arg_ + " must be on or off (got '" + text + "')";
    return false;
  }
  *value = text == "on";
  return true;
}

bool CommandLine::Integer(long lo, long hi, long* value) {
  std::string text;
  if (!Value(&text)) return false;
  char* end = nullptr;
  const long n = std::strtol(text.c_str(), &end, 10);
  if (text.empty() || *end != '\0' || n < lo || n > hi) {
    error_ = arg_ + " must be an integer in [" + std::to_string(lo) + ", " + std::to_string(hi) +
             "] (got '" + text + "')";
    return false;
  }
  *value = n;
  return true;
}

bool CommandLine::Number(double lo, double hi, double* value) {
  std::string text;
  if (!Value(&text)) return false;
  char* end = nullptr;
  const double x = std::strtod(text.c_str(), &end);
  if (text.empty() || *end != '\0' || !(x >= lo && x <= hi)) {
    error_ = arg_ + " must be a number in [" + ShortestDecimal(lo) + ", " + ShortestDecimal(hi) +
             "] (got '" + text + "')";
    return false;
  }
  *value = x;
  return true;
}

void CommandLine::Unknown() { error_ = "unknown option '" + arg_ + "' (see --help)"; }

int CommandLine::Fail(std::ostream& err) const {
  err << program_ << ": " << error_ << "\n";
  return kExitBadOption;
}

}  // namespace calibd::tools
