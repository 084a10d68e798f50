#pragma once
/// \file
/// The factory line's GPIO lines over libgpiod 1.6 (the C API v1, gpiod.h, kernel character
/// device uAPI v1): an `interlock` input (calibration allowed only while it is asserted), a
/// `start_button` input whose debounced press starts a calibration, and a `status_lamp` output
/// that shows the agent's state as a LampPattern. Every line is optional. libgpiod stays behind a
/// pimpl: nothing from gpiod.h appears here.
///
/// Config keys (the agent's YAML), `<line>` one of `interlock`, `start_button`, `status_lamp`:
/// - `agent.gpio.<line>.enabled` (default false): use this line; the other keys of a disabled
///   line are ignored.
/// - `agent.gpio.<line>.chip` (required when enabled): the gpiochip's label (`calibd-sim`), name
///   (`gpiochip0`), number (`0`) or path (`/dev/gpiochip0`), tried as libgpiod's
///   gpiod_chip_open_lookup() does.
/// - `agent.gpio.<line>.line` (required when enabled): the line's name on that chip
///   (`start_button`; the first line of that name: names are not unique), or its offset as a
///   decimal number (`1`). A value of digits only is always an offset.
/// - `agent.gpio.<line>.active_low` (default false): the line is asserted at the low physical
///   level (a button to ground with a pull-up, a lamp behind a low-side switch).
/// - `agent.gpio.start_button_debounce_ms` (default 30, 0..1000): how long the button's level
///   must stay unchanged before a change counts.
/// The lines are requested with the consumer name "calibd" (shown by `gpioinfo`); active_low is
/// applied here, not by the kernel, so `gpioinfo` shows physical levels.
///
/// Debounce (ButtonDebouncer): a level counts once it has stayed unchanged for the debounce time
/// after the last edge (not "first edge wins"): a glitch or bounce shorter than the debounce time
/// gives no press, a press with contact bounce gives exactly one, reported debounce_ms after its
/// last bounce. So the press becomes known only on a later HandleEvents(): the agent calls it when
/// event_fd() is readable and on every timer tick (or at debounce_deadline_us()).
///
/// Time: every `now_us` is CLOCK_MONOTONIC in microseconds (the agent's MonotonicUs()); the
/// kernel stamps v1 line events with the same clock (ktime_get_ns, Linux >= 5.7).
///
/// Threading: none of its own; one thread (the agent's poll loop) calls every method.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>

namespace calibd {

/// One GPIO line of the config.
struct GpioLineConfig {
  std::string chip;  ///< label (e.g. calibd-sim), name (gpiochip0), number or path
  std::string line;  ///< line name, or offset as a decimal number
  bool active_low = false;
  bool enabled = false;
};

struct GpioConfig {
  GpioLineConfig interlock;     ///< input: calibration allowed only while asserted
  GpioLineConfig start_button;  ///< input with edge events: a debounced press starts a calibration
  GpioLineConfig status_lamp;   ///< output: LampPattern of the agent's state
  /// The button's level must stay unchanged this long before it counts, ms. Longer rejects
  /// slower bounces and glitches but delays the press; mechanical buttons bounce for 1-10 ms.
  int start_button_debounce_ms = 30;

  static constexpr int kMaxDebounceMs = 1000;

  /// False with `error` naming the bad key (`agent.gpio.start_button.line`) when an enabled line
  /// has no chip or no line, the debounce is outside 0..kMaxDebounceMs, or two enabled lines
  /// name the same chip and line (as written).
  bool IsValid(std::string* error) const;
};

/// The line's offset when `line` is a decimal number (digits only, no sign, fits in 31 bits);
/// nullopt when it is a line name (or empty).
std::optional<unsigned> ParseGpioLineOffset(const std::string& line);

/// Logical level from the physical one: asserted = high, or low with active_low.
constexpr bool GpioLogicalLevel(bool physical_high, bool active_low) {
  return physical_high != active_low;
}

/// Pure debounce of one button: edges in, presses out (see the file comment). Allocation-free.
class ButtonDebouncer {
 public:
  /// `initial_level`: the logical level at start; a button held down at start gives no press
  /// until it has been released (stably) and pressed again.
  explicit ButtonDebouncer(int64_t debounce_us = 30000, bool initial_level = false)
      : debounce_us_(debounce_us), raw_level_(initial_level), stable_level_(initial_level) {}

  /// An edge seen at `t_us`, after which the logical level is `level`. Every edge restarts the
  /// debounce time, also one that repeats the current level (the kernel reports the level it
  /// reads when it handles the interrupt, so in a fast bounce the opposite edge may be missing).
  void Edge(int64_t t_us, bool level) {
    raw_level_ = level;
    last_edge_us_ = t_us;
  }

  /// True exactly once per press: when the level has been asserted for debounce_us since its
  /// last edge, at `now_us`, after a stable release. Call after feeding the edges up to now.
  bool Update(int64_t now_us) {
    if (raw_level_ == stable_level_ || now_us - last_edge_us_ < debounce_us_) return false;
    stable_level_ = raw_level_;
    return stable_level_;
  }

  /// An unconfirmed change waits: call Update() at or after debounce_deadline_us().
  bool pending() const { return raw_level_ != stable_level_; }
  /// When the waiting change will count if no edge comes first; meaningful while pending().
  int64_t debounce_deadline_us() const { return last_edge_us_ + debounce_us_; }
  /// The debounced logical level.
  bool stable_level() const { return stable_level_; }
  int64_t debounce_us() const { return debounce_us_; }

 private:
  int64_t debounce_us_;
  bool raw_level_;
  bool stable_level_;
  int64_t last_edge_us_ = 0;
};

/// What the status lamp shows.
enum class LampState {
  kIdle,     ///< off (a binary line cannot breathe; off keeps idle apart from every other state)
  kRunning,  ///< blinking at 1 Hz: 500 ms on, 500 ms off, starting on
  kSuccess,  ///< steadily on
  kFailure,  ///< blinking at 4 Hz: 125 ms on, 125 ms off, starting on
};

const char* LampStateName(LampState state);

/// Pure lamp patterns: the level at any time from the state and when it was set. Blinking starts
/// "on" at Set() so a state change shows at once. Allocation-free.
class LampPattern {
 public:
  static constexpr int64_t kRunningHalfPeriodUs = 500000;  ///< 1 Hz
  static constexpr int64_t kFailureHalfPeriodUs = 125000;  ///< 4 Hz

  /// Shows `state` from `now_us` on; setting the state already shown keeps its phase.
  void Set(LampState state, int64_t now_us) {
    if (state == state_) return;
    state_ = state;
    since_us_ = now_us;
  }
  LampState state() const { return state_; }

  /// The lamp's logical level at `now_us` (>= the last Set()'s time; earlier counts as then).
  bool Level(int64_t now_us) const;
  /// The time of the next level change after `now_us`; nullopt for a steady pattern. The agent
  /// may shorten its poll timeout to it (a 50 ms tick shifts the 4 Hz edges by up to 50 ms).
  std::optional<int64_t> NextChangeUs(int64_t now_us) const;

 private:
  LampState state_ = LampState::kIdle;
  int64_t since_us_ = 0;
};

/// The enabled lines, requested from the kernel for as long as the object lives (RAII).
class GpioLines {
 public:
  static constexpr const char* kConsumer = "calibd";

  GpioLines();
  ~GpioLines();
  GpioLines(const GpioLines&) = delete;
  GpioLines& operator=(const GpioLines&) = delete;

  /// Validates `config` and requests its enabled lines: interlock as input, start_button as
  /// input with both-edge events (its event fd set non-blocking), status_lamp as output driven
  /// off. False with `error` naming the key, chip and line when: the config is invalid; the chip
  /// cannot be opened (the error lists the chips present); the line name is not on the chip or
  /// the offset beyond it (the error lists the chip's lines); the line is already requested (the
  /// error names its consumer); or the kernel refused the request. On failure no line is held.
  /// Drops any earlier state.
  bool Open(const GpioConfig& config, std::string* error);
  /// Releases every line (the lamp keeps its last level: the kernel leaves an output as it was).
  void Close();

  bool has_interlock() const;
  bool has_start_button() const;
  bool has_status_lamp() const;

  /// The start button's event fd for the poll loop (POLLIN); -1 without a start button.
  int event_fd() const;

  /// Reads the start button's pending edge events (never blocks) and returns true when a
  /// debounced press completed by `now_us`. Call when event_fd() is readable and on every timer
  /// tick. False without a start button. A failed read is counted (io_errors()).
  bool HandleEvents(int64_t now_us);
  /// When HandleEvents() should run at the latest to report a pending press; nullopt when no
  /// change waits.
  std::optional<int64_t> debounce_deadline_us() const;

  /// The interlock's logical level, read now: true when asserted. True when no interlock line is
  /// configured (nothing restricts calibration); false when the read fails (fail safe, counted).
  bool interlock();

  /// Drives the lamp to the logical level `on` now (no-op without a lamp). False when the kernel
  /// refused the write (counted).
  bool SetLamp(bool on);
  /// Shows `state` from `now_us`; the line changes on the next UpdateLamp().
  void SetLampState(LampState state, int64_t now_us);
  /// Applies the pattern's level at `now_us`, writing the line only when the level changes.
  void UpdateLamp(int64_t now_us);
  const LampPattern& lamp_pattern() const;

  /// Edge events read from the start button since Open().
  int64_t events_read() const;
  /// Failed reads of events or levels and failed lamp writes since Open().
  int64_t io_errors() const;
  /// Lamp writes since Open() (SetLamp and UpdateLamp): a steady pattern writes once.
  int64_t lamp_writes() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace calibd
