#include "calibd/drivers/gpio_lines.hpp"

#include <fcntl.h>
#include <gpiod.h>
#include <poll.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <iterator>
#include <limits>
#include <utility>

#include "calibd/core/common/validation.hpp"

namespace calibd {

namespace {

bool AllDigits(const std::string& s) {
  return !s.empty() && std::all_of(s.begin(), s.end(), [](char c) { return c >= '0' && c <= '9'; });
}

std::string Quoted(const std::string& s) { return "\"" + s + "\""; }

struct ChipCloser {
  void operator()(gpiod_chip* chip) const { gpiod_chip_close(chip); }
};
using ChipPtr = std::unique_ptr<gpiod_chip, ChipCloser>;

/// One requested line and the chip handle it belongs to: released, then the chip closed.
struct RequestedLine {
  ChipPtr chip;
  gpiod_line* line = nullptr;  ///< owned by `chip`; requested by us
  bool active_low = false;
  std::string what;  ///< "agent.gpio.status_lamp (gpiochip0 [calibd-sim] line 2 "status_lamp")"

  RequestedLine() = default;
  RequestedLine(const RequestedLine&) = delete;
  RequestedLine& operator=(const RequestedLine&) = delete;
  ~RequestedLine() {
    if (line != nullptr) gpiod_line_release(line);
  }
};

std::string ChipDescription(gpiod_chip* chip) {
  return std::string(gpiod_chip_name(chip)) + " [" + gpiod_chip_label(chip) + "]";
}

/// "gpiochip0 [calibd-sim], gpiochip1 [...]", for errors.
std::string ListChips() {
  gpiod_chip_iter* iter = gpiod_chip_iter_new();
  if (iter == nullptr) return std::string("(cannot list them: ") + std::strerror(errno) + ")";
  std::string list;
  for (gpiod_chip* chip = gpiod_chip_iter_next(iter); chip != nullptr;
       chip = gpiod_chip_iter_next(iter)) {
    list += (list.empty() ? "" : ", ") + ChipDescription(chip);
  }
  gpiod_chip_iter_free(iter);  // closes the last chip handle
  return list.empty() ? "none" : list;
}

/// `0 "interlock", 1 "start_button", ..., 4 (unnamed)`, for errors.
std::string ListLines(gpiod_chip* chip) {
  std::string list;
  const unsigned n = gpiod_chip_num_lines(chip);
  for (unsigned offset = 0; offset < n; ++offset) {
    gpiod_line* line = gpiod_chip_get_line(chip, offset);
    const char* name = line != nullptr ? gpiod_line_name(line) : nullptr;
    list += (offset == 0 ? "" : ", ") + std::to_string(offset) + " " +
            (name != nullptr && name[0] != '\0' ? Quoted(name) : std::string("(unnamed)"));
  }
  return list.empty() ? "no lines" : list;
}

/// Opens the chip and requests the line of `config` (key `key`, e.g. "agent.gpio.interlock")
/// with `request_type` (GPIOD_LINE_REQUEST_*); `default_physical` is an output's initial level.
std::unique_ptr<RequestedLine> RequestLine(const std::string& key, const GpioLineConfig& config,
                                           int request_type, bool default_physical,
                                           std::string* error) {
  auto fail = [&](const std::string& message) {
    if (error) *error = message;
    return nullptr;
  };
  auto requested = std::make_unique<RequestedLine>();
  requested->active_low = config.active_low;
  errno = 0;
  requested->chip.reset(gpiod_chip_open_lookup(config.chip.c_str()));
  if (!requested->chip) {
    const int err = errno;
    return fail(key + ".chip: cannot open GPIO chip " + Quoted(config.chip) + " (" +
                (err == 0 ? "not found" : std::strerror(err)) + "); chips present: " + ListChips());
  }
  gpiod_chip* chip = requested->chip.get();
  const std::string chip_text = ChipDescription(chip);
  gpiod_line* line = nullptr;
  if (const std::optional<unsigned> offset = ParseGpioLineOffset(config.line)) {
    if (*offset >= gpiod_chip_num_lines(chip)) {
      return fail(key + ".line: offset " + config.line + " is beyond chip " + chip_text + " (" +
                  std::to_string(gpiod_chip_num_lines(chip)) + " lines: " + ListLines(chip) + ")");
    }
    line = gpiod_chip_get_line(chip, *offset);
  } else {
    line = gpiod_chip_find_line(chip, config.line.c_str());
    if (line == nullptr) {
      return fail(key + ".line: no line named " + Quoted(config.line) + " on chip " + chip_text +
                  " (its lines: " + ListLines(chip) + ")");
    }
  }
  if (line == nullptr) {
    return fail(key + ".line: cannot get line " + config.line + " of chip " + chip_text + ": " +
                std::strerror(errno));
  }
  const char* name = gpiod_line_name(line);
  requested->what = key + " (" + chip_text + " line " + std::to_string(gpiod_line_offset(line)) +
                    (name != nullptr && name[0] != '\0' ? " " + Quoted(name) : std::string()) + ")";

  gpiod_line_request_config request{};
  request.consumer = GpioLines::kConsumer;
  request.request_type = request_type;
  request.flags = 0;  // active_low is applied by us: events and gpioinfo stay physical
  if (gpiod_line_request(line, &request, default_physical ? 1 : 0) != 0) {
    const int err = errno;
    if (err == EBUSY) {
      gpiod_line_update(line);
      const char* consumer = gpiod_line_consumer(line);
      return fail(requested->what + ": line busy, already requested by " +
                  (consumer != nullptr && consumer[0] != '\0' ? "consumer " + Quoted(consumer)
                                                              : std::string("another consumer")));
    }
    return fail(requested->what + ": request refused: " + std::strerror(err));
  }
  requested->line = line;
  return requested;
}

}  // namespace

// --- config ---

std::optional<unsigned> ParseGpioLineOffset(const std::string& line) {
  if (!AllDigits(line) || line.size() > 10) return std::nullopt;
  const unsigned long long value = std::stoull(line);
  if (value > static_cast<unsigned long long>(std::numeric_limits<int32_t>::max())) {
    return std::nullopt;
  }
  return static_cast<unsigned>(value);
}

bool GpioConfig::IsValid(std::string* error) const {
  struct Named {
    const char* key;
    const GpioLineConfig* line;
  };
  const Named lines[] = {{"agent.gpio.interlock", &interlock},
                         {"agent.gpio.start_button", &start_button},
                         {"agent.gpio.status_lamp", &status_lamp}};
  for (const Named& n : lines) {
    if (!n.line->enabled) continue;
    const std::string key = n.key;
    if (n.line->chip.empty()) {
      return Invalid(error, key + ".chip: required when " + key +
                                ".enabled is true (a chip label, name, number or path)");
    }
    if (n.line->line.empty()) {
      return Invalid(error, key + ".line: required when " + key +
                                ".enabled is true (a line name, or an offset as a number)");
    }
    if (AllDigits(n.line->line) && !ParseGpioLineOffset(n.line->line)) {
      return Invalid(error, key + ".line: offset " + n.line->line + " is out of range");
    }
  }
  for (size_t i = 0; i < std::size(lines); ++i) {
    for (size_t j = i + 1; j < std::size(lines); ++j) {
      const GpioLineConfig& a = *lines[i].line;
      const GpioLineConfig& b = *lines[j].line;
      if (a.enabled && b.enabled && a.chip == b.chip && a.line == b.line) {
        return Invalid(error, std::string(lines[j].key) + ": chip " + Quoted(b.chip) + " line " +
                                  Quoted(b.line) + " is already " + lines[i].key + "'s");
      }
    }
  }
  if (start_button_debounce_ms < 0 || start_button_debounce_ms > kMaxDebounceMs) {
    return Invalid(
        error, "agent.gpio.start_button_debounce_ms: " + std::to_string(start_button_debounce_ms) +
                   " is outside 0.." + std::to_string(kMaxDebounceMs));
  }
  return true;
}

// --- lamp pattern ---

const char* LampStateName(LampState state) {
  switch (state) {
    case LampState::kIdle:
      return "idle";
    case LampState::kRunning:
      return "running";
    case LampState::kSuccess:
      return "success";
    case LampState::kFailure:
      return "failure";
  }
  return "?";
}

namespace {
/// Half period of a blinking state; 0 for a steady one.
int64_t HalfPeriodUs(LampState state) {
  switch (state) {
    case LampState::kRunning:
      return LampPattern::kRunningHalfPeriodUs;
    case LampState::kFailure:
      return LampPattern::kFailureHalfPeriodUs;
    case LampState::kIdle:
    case LampState::kSuccess:
      break;
  }
  return 0;
}
}  // namespace

bool LampPattern::Level(int64_t now_us) const {
  const int64_t half = HalfPeriodUs(state_);
  if (half == 0) return state_ == LampState::kSuccess;
  const int64_t dt = std::max<int64_t>(0, now_us - since_us_);
  return (dt / half) % 2 == 0;
}

std::optional<int64_t> LampPattern::NextChangeUs(int64_t now_us) const {
  const int64_t half = HalfPeriodUs(state_);
  if (half == 0) return std::nullopt;
  const int64_t dt = std::max<int64_t>(0, now_us - since_us_);
  return since_us_ + (dt / half + 1) * half;
}

// --- lines ---

struct GpioLines::Impl {
  std::unique_ptr<RequestedLine> interlock;
  std::unique_ptr<RequestedLine> start_button;
  std::unique_ptr<RequestedLine> status_lamp;
  int event_fd = -1;
  ButtonDebouncer debouncer;
  LampPattern lamp;
  std::optional<bool> lamp_level;  ///< last logical level written
  int64_t events_read = 0;
  int64_t io_errors = 0;
  int64_t lamp_writes = 0;
};

GpioLines::GpioLines() : impl_(std::make_unique<Impl>()) {}
GpioLines::~GpioLines() = default;

bool GpioLines::Open(const GpioConfig& config, std::string* error) {
  Close();
  if (!config.IsValid(error)) return false;
  auto next = std::make_unique<Impl>();
  if (config.interlock.enabled) {
    next->interlock = RequestLine("agent.gpio.interlock", config.interlock,
                                  GPIOD_LINE_REQUEST_DIRECTION_INPUT, false, error);
    if (!next->interlock) return false;
  }
  if (config.start_button.enabled) {
    next->start_button = RequestLine("agent.gpio.start_button", config.start_button,
                                     GPIOD_LINE_REQUEST_EVENT_BOTH_EDGES, false, error);
    if (!next->start_button) return false;
    RequestedLine& button = *next->start_button;
    next->event_fd = gpiod_line_event_get_fd(button.line);
    const int flags = next->event_fd >= 0 ? fcntl(next->event_fd, F_GETFL) : -1;
    if (flags < 0 || fcntl(next->event_fd, F_SETFL, flags | O_NONBLOCK) != 0) {
      if (error) *error = button.what + ": cannot set up its event fd: " + std::strerror(errno);
      return false;
    }
    const int value = gpiod_line_get_value(button.line);
    if (value < 0) {
      if (error) *error = button.what + ": cannot read its level: " + std::strerror(errno);
      return false;
    }
    next->debouncer = ButtonDebouncer(int64_t{config.start_button_debounce_ms} * 1000,
                                      GpioLogicalLevel(value == 1, config.start_button.active_low));
  }
  if (config.status_lamp.enabled) {
    // Off from the start: the logical low is the physical high when active low.
    next->status_lamp =
        RequestLine("agent.gpio.status_lamp", config.status_lamp,
                    GPIOD_LINE_REQUEST_DIRECTION_OUTPUT, config.status_lamp.active_low, error);
    if (!next->status_lamp) return false;
    next->lamp_level = false;
  }
  impl_ = std::move(next);
  return true;
}

void GpioLines::Close() { impl_ = std::make_unique<Impl>(); }

bool GpioLines::has_interlock() const { return impl_->interlock != nullptr; }
bool GpioLines::has_start_button() const { return impl_->start_button != nullptr; }
bool GpioLines::has_status_lamp() const { return impl_->status_lamp != nullptr; }
int GpioLines::event_fd() const { return impl_->event_fd; }

bool GpioLines::HandleEvents(int64_t now_us) {
  Impl& s = *impl_;
  if (!s.start_button) return false;
  // v1 line events: the kernel queues up to 16 per line; one read returns all that wait.
  constexpr unsigned kBatch = 16;
  gpiod_line_event events[kBatch];
  for (int round = 0; round < 8; ++round) {
    pollfd p{s.event_fd, POLLIN, 0};
    if (poll(&p, 1, 0) <= 0 || (p.revents & POLLIN) == 0) break;
    const int n = gpiod_line_event_read_multiple(s.start_button->line, events, kBatch);
    if (n < 0) {
      if (errno != EAGAIN) ++s.io_errors;
      break;
    }
    for (int i = 0; i < n; ++i) {
      const gpiod_line_event& e = events[i];
      const int64_t t_us = int64_t{e.ts.tv_sec} * 1000000 + e.ts.tv_nsec / 1000;
      s.debouncer.Edge(t_us, GpioLogicalLevel(e.event_type == GPIOD_LINE_EVENT_RISING_EDGE,
                                              s.start_button->active_low));
    }
    s.events_read += n;
    if (n < static_cast<int>(kBatch)) break;
  }
  return s.debouncer.Update(now_us);
}

std::optional<int64_t> GpioLines::debounce_deadline_us() const {
  if (!impl_->start_button || !impl_->debouncer.pending()) return std::nullopt;
  return impl_->debouncer.debounce_deadline_us();
}

bool GpioLines::interlock() {
  Impl& s = *impl_;
  if (!s.interlock) return true;
  const int value = gpiod_line_get_value(s.interlock->line);
  if (value < 0) {
    ++s.io_errors;
    return false;
  }
  return GpioLogicalLevel(value == 1, s.interlock->active_low);
}

bool GpioLines::SetLamp(bool on) {
  Impl& s = *impl_;
  if (!s.status_lamp) return true;
  ++s.lamp_writes;
  if (gpiod_line_set_value(s.status_lamp->line, on != s.status_lamp->active_low ? 1 : 0) != 0) {
    ++s.io_errors;
    s.lamp_level.reset();  // unknown: the next UpdateLamp writes again
    return false;
  }
  s.lamp_level = on;
  return true;
}

void GpioLines::SetLampState(LampState state, int64_t now_us) { impl_->lamp.Set(state, now_us); }

void GpioLines::UpdateLamp(int64_t now_us) {
  Impl& s = *impl_;
  if (!s.status_lamp) return;
  const bool level = s.lamp.Level(now_us);
  if (s.lamp_level != level) SetLamp(level);
}

const LampPattern& GpioLines::lamp_pattern() const { return impl_->lamp; }
int64_t GpioLines::events_read() const { return impl_->events_read; }
int64_t GpioLines::io_errors() const { return impl_->io_errors; }
int64_t GpioLines::lamp_writes() const { return impl_->lamp_writes; }

}  // namespace calibd
