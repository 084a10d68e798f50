#include "command_line.hpp"

#include <cmath>
#include <cstdlib>

#include "calibd/drivers/config_file.hpp"

namespace calibd::tools {

std::vector<std::string> SplitList(const std::string& text) {
  std::vector<std::string> items;
  size_t start = 0;
  for (;;) {
    const size_t comma = text.find(',', start);
    items.push_back(text.substr(start, comma == std::string::npos ? comma : comma - start));
    if (comma == std::string::npos) return items;
    start = comma + 1;
  }
}

namespace {

// `text` as a whole as an integer; false when anything else is in it.
bool ParseLong(const std::string& text, long* value) {
  char* end = nullptr;
  *value = std::strtol(text.c_str(), &end, 10);
  return !text.empty() && *end == '\0';
}

// `text` as a whole as a number; false when anything else is in it.
bool ParseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && *end == '\0';
}

// " [lo, hi]" with its unit, for the errors.
std::string Range(const std::string& lo, const std::string& hi, std::string_view unit) {
  std::string range = " in [" + lo + ", " + hi + "]";
  if (!unit.empty()) range += " " + std::string(unit);
  return range;
}

// "2", "1 to 12", "1 or more": how many items a list takes, for the errors.
std::string CountText(Count count) {
  if (count.min == count.max) return std::to_string(count.min);
  if (count.max == Count{}.max) return std::to_string(count.min) + " or more";
  return std::to_string(count.min) + " to " + std::to_string(count.max);
}

// `text`'s comma-separated items into `values` when there are `count` of them and `parse` takes
// each; else false, `values` untouched.
template <typename T, typename Parse>
bool ParseList(const std::string& text, Count count, Parse parse, std::vector<T>* values) {
  const std::vector<std::string> items = SplitList(text);
  if (items.size() < count.min || items.size() > count.max) return false;
  std::vector<T> parsed(items.size());
  for (size_t i = 0; i < items.size(); ++i)
    if (!parse(items[i], &parsed[i])) return false;
  *values = std::move(parsed);
  return true;
}

}  // namespace

CommandLine::CommandLine(std::string program, int argc, char** argv)
    : program_(std::move(program)) {
  for (int i = 1; i < argc; ++i) args_.emplace_back(argv[i]);
}

bool CommandLine::Next() {
  if (failed()) return false;
  if (has_inline_ && !inline_used_) {  // a flag the tool took without its value
    error_ = "option " + arg_ + " takes no value (got '" + arg_ + "=" + inline_value_ + "')";
    return false;
  }
  if (next_ >= args_.size()) return false;
  arg_ = args_[next_++];
  has_inline_ = inline_used_ = false;
  if (const size_t eq = arg_.find('=');
      inline_values_ && arg_.rfind("--", 0) == 0 && eq != std::string::npos) {
    inline_value_ = arg_.substr(eq + 1);
    arg_.resize(eq);
    has_inline_ = true;
  }
  return true;
}

bool CommandLine::Value(std::string* value) {
  if (has_inline_) {
    inline_used_ = true;
    *value = inline_value_;
    return true;
  }
  if (next_ >= args_.size()) {
    error_ = "option " + arg_ + " needs a value (see --help)";
    return false;
  }
  *value = args_[next_++];
  return true;
}

bool CommandLine::Refuse(const std::string& what, const std::string& text) {
  error_ = arg_ + " must be " + what + " (got '" + text + "')";
  return false;
}

bool CommandLine::Text(std::string* value) {
  std::string text;
  if (!Value(&text)) return false;
  if (text.empty()) return Refuse("a non-empty value", text);
  *value = text;
  return true;
}

bool CommandLine::OnOff(bool* value) {
  std::string text;
  if (!Value(&text)) return false;
  if (text != "on" && text != "off") return Refuse("on or off", text);
  *value = text == "on";
  return true;
}

bool CommandLine::Integer(long lo, long hi, long* value, std::string_view unit) {
  std::string text;
  if (!Value(&text)) return false;
  long n = 0;
  if (!ParseLong(text, &n) || n < lo || n > hi)
    return Refuse("an integer" + Range(std::to_string(lo), std::to_string(hi), unit), text);
  *value = n;
  return true;
}

bool CommandLine::Integer(int lo, int hi, int* value, std::string_view unit) {
  long n = 0;
  if (!Integer(lo, hi, &n, unit)) return false;
  *value = static_cast<int>(n);
  return true;
}

bool CommandLine::Number(double lo, double hi, double* value, std::string_view unit) {
  std::string text;
  if (!Value(&text)) return false;
  double x = 0.0;
  if (!ParseDouble(text, &x) || !(x >= lo && x <= hi))
    return Refuse("a number" + Range(ShortestDecimal(lo), ShortestDecimal(hi), unit), text);
  *value = x;
  return true;
}

bool CommandLine::Numbers(Count count, std::vector<double>* values) {
  std::string text;
  if (!Value(&text)) return false;
  const auto finite = [](const std::string& item, double* x) {
    return ParseDouble(item, x) && std::isfinite(*x);
  };
  if (!ParseList(text, count, finite, values))
    return Refuse(CountText(count) + " comma-separated numbers", text);
  return true;
}

bool CommandLine::Integers(Count count, long lo, long hi, std::vector<long>* values) {
  std::string text;
  if (!Value(&text)) return false;
  const auto in_range = [=](const std::string& item, long* n) {
    return ParseLong(item, n) && *n >= lo && *n <= hi;
  };
  if (!ParseList(text, count, in_range, values))
    return Refuse(CountText(count) + " comma-separated integers" +
                      Range(std::to_string(lo), std::to_string(hi), {}),
                  text);
  return true;
}

void CommandLine::Unknown() { error_ = "unknown option '" + arg_ + "' (see --help)"; }

int CommandLine::Fail(std::ostream& err) const {
  err << program_ << ": " << error_ << "\n";
  return kExitBadOption;
}

}  // namespace calibd::tools
