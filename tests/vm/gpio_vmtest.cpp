// Inside the test VM: GpioLines (drivers/gpio_lines.hpp) on the real gpio-sim chip `calibd-sim`
// (tests/vm/guest-init.sh: lines 0 interlock, 1 start_button, 2 status_lamp, 3 spare, 4-7
// unnamed). The simulator's side (CALIBD_VM_GPIOSIM/sim_gpioN/{pull,value}) plays the factory
// line: it pulls the inputs and reads the lamp output.

#include <gpiod.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include "calibd/drivers/gpio_lines.hpp"

namespace calibd {
namespace {

constexpr unsigned kInterlock = 0;
constexpr unsigned kStartButton = 1;
constexpr unsigned kStatusLamp = 2;
constexpr const char* kLabel = "calibd-sim";

int64_t NowUs() {
  timespec ts{};
  clock_gettime(CLOCK_MONOTONIC, &ts);
  return int64_t{ts.tv_sec} * 1000000 + ts.tv_nsec / 1000;
}

std::string Env(const char* name) {
  const char* value = std::getenv(name);
  return value != nullptr ? value : "";
}

class GpioVmTest : public ::testing::Test {
 protected:
  void SetUp() override {
    chip_ = Env("CALIBD_VM_GPIOCHIP");
    sim_ = Env("CALIBD_VM_GPIOSIM");
    ASSERT_FALSE(chip_.empty() || sim_.empty())
        << "not inside the test VM (CALIBD_VM_GPIOCHIP / CALIBD_VM_GPIOSIM unset): run with "
           "ctest -R gpio_vmtest";
    // Every line at rest: pulled down.
    for (unsigned offset : {kInterlock, kStartButton, kStatusLamp}) Pull(offset, false);
  }

  /// The simulator pulls line `offset` up or down (what a switch on the line does).
  void Pull(unsigned offset, bool up) {
    const std::string path = sim_ + "/sim_gpio" + std::to_string(offset) + "/pull";
    std::ofstream out(path);
    out << (up ? "pull-up" : "pull-down");
    out.close();
    ASSERT_TRUE(out) << "cannot write " << path;
  }

  /// The physical level of line `offset` as the simulator sees it (an output: what is driven).
  int SimValue(unsigned offset) {
    std::ifstream in(sim_ + "/sim_gpio" + std::to_string(offset) + "/value");
    int value = -1;
    in >> value;
    return value;
  }

  static GpioLineConfig Line(std::string chip, std::string line, bool active_low = false) {
    GpioLineConfig c;
    c.chip = std::move(chip);
    c.line = std::move(line);
    c.active_low = active_low;
    c.enabled = true;
    return c;
  }

  /// Runs the poll loop as the agent does for `duration_ms`: poll the event fd (10 ms timeout, the
  /// agent's tick stands in), HandleEvents on every wake. Returns the presses' times.
  static std::vector<int64_t> RunLoop(GpioLines& gpio, int duration_ms) {
    std::vector<int64_t> presses;
    const int64_t end = NowUs() + int64_t{duration_ms} * 1000;
    while (NowUs() < end) {
      pollfd p{gpio.event_fd(), POLLIN, 0};
      poll(&p, 1, 10);
      const int64_t now = NowUs();
      if (gpio.HandleEvents(now)) presses.push_back(now);
    }
    return presses;
  }

  std::string chip_;  ///< e.g. gpiochip0
  std::string sim_;   ///< the simulator's sysfs folder
};

TEST_F(GpioVmTest, OpensByLabelNameNumberPathAndOffsetAsConsumerCalibd) {
  GpioConfig config;
  config.interlock = Line(kLabel, "interlock");               // label + line name
  config.start_button = Line(chip_, "1");                     // chip name + offset
  config.status_lamp = Line("/dev/" + chip_, "status_lamp");  // path + line name
  GpioLines gpio;
  std::string error;
  ASSERT_TRUE(gpio.Open(config, &error)) << error;
  EXPECT_TRUE(gpio.has_interlock());
  EXPECT_TRUE(gpio.has_start_button());
  EXPECT_TRUE(gpio.has_status_lamp());
  EXPECT_GE(gpio.event_fd(), 0);

  // The kernel shows the three lines requested by "calibd".
  gpiod_chip* chip = gpiod_chip_open_by_label(kLabel);
  ASSERT_NE(chip, nullptr);
  for (unsigned offset : {kInterlock, kStartButton, kStatusLamp}) {
    gpiod_line* line = gpiod_chip_get_line(chip, offset);
    ASSERT_NE(line, nullptr);
    EXPECT_TRUE(gpiod_line_is_used(line)) << "line " << offset;
    const char* consumer = gpiod_line_consumer(line);
    EXPECT_STREQ(consumer != nullptr ? consumer : "", "calibd") << "line " << offset;
  }
  gpiod_chip_close(chip);

  // Close releases them.
  gpio.Close();
  chip = gpiod_chip_open_by_label(kLabel);
  ASSERT_NE(chip, nullptr);
  EXPECT_FALSE(gpiod_line_is_used(gpiod_chip_get_line(chip, kStartButton)));
  gpiod_chip_close(chip);

  // The chip by number (gpiochipN -> N) opens too.
  GpioConfig by_number;
  by_number.interlock = Line(chip_.substr(std::string("gpiochip").size()), "0");
  ASSERT_TRUE(gpio.Open(by_number, &error)) << error;
  EXPECT_TRUE(gpio.has_interlock());
}

TEST_F(GpioVmTest, InterlockReadsTheSimulatorsPullWithActiveLow) {
  for (bool active_low : {false, true}) {
    SCOPED_TRACE(active_low ? "active_low" : "active high");
    GpioConfig config;
    config.interlock = Line(kLabel, "interlock", active_low);
    GpioLines gpio;
    std::string error;
    ASSERT_TRUE(gpio.Open(config, &error)) << error;
    for (bool up : {true, false, true, false}) {
      Pull(kInterlock, up);
      EXPECT_EQ(gpio.interlock(), up != active_low) << (up ? "pull-up" : "pull-down");
    }
    EXPECT_EQ(gpio.io_errors(), 0);
  }
}

TEST_F(GpioVmTest, StartButtonPressGivesExactlyOneDebouncedPress) {
  for (bool active_low : {false, true}) {
    SCOPED_TRACE(active_low ? "active_low (button to ground)" : "active high");
    Pull(kStartButton, active_low);  // released
    GpioConfig config;
    config.start_button = Line(kLabel, "start_button", active_low);
    config.start_button_debounce_ms = 30;
    GpioLines gpio;
    std::string error;
    ASSERT_TRUE(gpio.Open(config, &error)) << error;
    EXPECT_TRUE(RunLoop(gpio, 100).empty()) << "no press before the button is pressed";

    const int64_t pressed_at = NowUs();
    Pull(kStartButton, !active_low);  // press...
    std::vector<int64_t> presses = RunLoop(gpio, 200);
    Pull(kStartButton, active_low);  // ... and release
    const std::vector<int64_t> after_release = RunLoop(gpio, 200);
    presses.insert(presses.end(), after_release.begin(), after_release.end());

    ASSERT_EQ(presses.size(), 1u) << "one press, one release";
    // Known only once the level held for the debounce time; within a few ticks after it.
    EXPECT_GE(presses[0] - pressed_at, 30000);
    EXPECT_LT(presses[0] - pressed_at, 150000);
    EXPECT_GE(gpio.events_read(), 2) << "both edges came through the event fd";
    EXPECT_EQ(gpio.io_errors(), 0);
    std::printf("press (%s) reported %.1f ms after the pull, %lld events\n",
                active_low ? "active low" : "active high",
                static_cast<double>(presses[0] - pressed_at) / 1000.0,
                static_cast<long long>(gpio.events_read()));
  }
}

TEST_F(GpioVmTest, BounceShorterThanTheDebounceGivesNoPressBouncyPressGivesOne) {
  GpioConfig config;
  config.start_button = Line(kLabel, "start_button");
  config.start_button_debounce_ms = 100;  // margin for the slow VM between two sysfs writes
  GpioLines gpio;
  std::string error;
  ASSERT_TRUE(gpio.Open(config, &error)) << error;

  // A glitch: up and down again at once.
  const int64_t t0 = NowUs();
  Pull(kStartButton, true);
  Pull(kStartButton, false);
  const int64_t glitch_us = NowUs() - t0;
  ASSERT_LT(glitch_us, 50000) << "the VM took too long between two writes to test a glitch";
  EXPECT_TRUE(RunLoop(gpio, 300).empty()) << "a " << glitch_us << " us glitch gave a press";
  EXPECT_GE(gpio.events_read(), 1) << "the glitch's edges reached the event fd";
  const int64_t glitch_events = gpio.events_read();

  // A press with contact bounce (up, down, up), held, released with bounce (down, up, down).
  for (bool up : {true, false, true}) Pull(kStartButton, up);
  const std::vector<int64_t> pressed = RunLoop(gpio, 300);
  for (bool up : {false, true, false}) Pull(kStartButton, up);
  const std::vector<int64_t> released = RunLoop(gpio, 300);
  EXPECT_EQ(pressed.size(), 1u);
  EXPECT_TRUE(released.empty());
  EXPECT_GE(gpio.events_read() - glitch_events, 2);
  std::printf("glitch %.2f ms: no press; bouncy press: %zu press, %lld events in all\n",
              static_cast<double>(glitch_us) / 1000.0, pressed.size() + released.size(),
              static_cast<long long>(gpio.events_read()));
}

struct Samples {
  std::vector<int64_t> t_us;
  std::vector<int> value;
};

/// Level changes seen by the simulator, and the blink rate from the first to the last change.
struct Blink {
  int transitions = 0;
  double rate_hz = 0;  ///< periods per second; 0 with fewer than 3 changes
};

Blink Measure(const Samples& s) {
  Blink b;
  int64_t first = -1;
  int64_t last = -1;
  for (size_t i = 1; i < s.value.size(); ++i) {
    if (s.value[i] == s.value[i - 1]) continue;
    ++b.transitions;
    if (first < 0) first = s.t_us[i];
    last = s.t_us[i];
  }
  // Two changes per period.
  if (b.transitions >= 3)
    b.rate_hz = (b.transitions - 1) / 2.0 / (static_cast<double>(last - first) * 1e-6);
  return b;
}

TEST_F(GpioVmTest, LampPatternsSeenFromTheSimulator) {
  Pull(kStatusLamp, true);  // pulled against the output: the simulator must see what we drive
  GpioConfig config;
  config.status_lamp = Line(kLabel, "status_lamp");
  GpioLines gpio;
  std::string error;
  ASSERT_TRUE(gpio.Open(config, &error)) << error;
  EXPECT_EQ(SimValue(kStatusLamp), 0) << "the lamp starts off";

  // The agent's loop: UpdateLamp on every tick (here 5 ms); the simulator samples the line.
  auto run = [&](LampState state, int duration_ms) {
    Samples s;
    const int64_t t0 = NowUs();
    gpio.SetLampState(state, t0);
    s.t_us.push_back(t0);
    s.value.push_back(SimValue(kStatusLamp));
    while (NowUs() < t0 + int64_t{duration_ms} * 1000) {
      gpio.UpdateLamp(NowUs());
      s.t_us.push_back(NowUs());
      s.value.push_back(SimValue(kStatusLamp));
      usleep(5000);
    }
    return s;
  };

  int64_t writes = gpio.lamp_writes();
  const Blink running = Measure(run(LampState::kRunning, 2500));
  const int64_t running_writes = gpio.lamp_writes() - writes;
  std::printf("running: %d transitions in 2.5 s, %.3f Hz, %lld writes\n", running.transitions,
              running.rate_hz, static_cast<long long>(running_writes));
  EXPECT_GE(running.transitions, 4);  // on at 0, off 0.5, on 1.0, off 1.5, on 2.0, (off 2.5)
  EXPECT_LE(running.transitions, 6);
  EXPECT_NEAR(running.rate_hz, 1.0, 0.15);
  EXPECT_LE(running_writes, running.transitions + 1) << "writes only on changes";

  writes = gpio.lamp_writes();
  const Samples success = run(LampState::kSuccess, 1000);
  std::printf("success: %zu samples, %lld writes\n", success.value.size(),
              static_cast<long long>(gpio.lamp_writes() - writes));
  for (size_t i = 1; i < success.value.size(); ++i) ASSERT_EQ(success.value[i], 1) << i;
  EXPECT_LE(gpio.lamp_writes() - writes, 1) << "a steady pattern writes at most once";

  writes = gpio.lamp_writes();
  const Blink failure = Measure(run(LampState::kFailure, 2500));
  std::printf("failure: %d transitions in 2.5 s, %.3f Hz, %lld writes\n", failure.transitions,
              failure.rate_hz, static_cast<long long>(gpio.lamp_writes() - writes));
  EXPECT_GE(failure.transitions, 17);  // a change every 125 ms: 20 in 2.5 s
  EXPECT_LE(failure.transitions, 21);
  EXPECT_NEAR(failure.rate_hz, 4.0, 0.5);

  const Samples idle = run(LampState::kIdle, 500);
  for (size_t i = 1; i < idle.value.size(); ++i) ASSERT_EQ(idle.value[i], 0) << i;
  EXPECT_EQ(gpio.io_errors(), 0);
}

TEST_F(GpioVmTest, ActiveLowLampDrivesThePhysicalLowForOn) {
  GpioConfig config;
  config.status_lamp = Line(kLabel, "status_lamp", /*active_low=*/true);
  GpioLines gpio;
  std::string error;
  ASSERT_TRUE(gpio.Open(config, &error)) << error;
  EXPECT_EQ(SimValue(kStatusLamp), 1) << "off = physical high";
  ASSERT_TRUE(gpio.SetLamp(true));
  EXPECT_EQ(SimValue(kStatusLamp), 0);
  ASSERT_TRUE(gpio.SetLamp(false));
  EXPECT_EQ(SimValue(kStatusLamp), 1);
}

TEST_F(GpioVmTest, MissingLineChipOrOffsetIsNamedWithWhatThereIs) {
  GpioLines gpio;
  std::string error;

  GpioConfig config;
  config.start_button = Line(kLabel, "start_buton");
  EXPECT_FALSE(gpio.Open(config, &error));
  std::printf("missing line: %s\n", error.c_str());
  EXPECT_NE(error.find("agent.gpio.start_button.line"), std::string::npos) << error;
  EXPECT_NE(error.find("\"start_buton\""), std::string::npos) << error;
  EXPECT_NE(error.find(kLabel), std::string::npos) << error;
  EXPECT_NE(error.find("1 \"start_button\""), std::string::npos) << "lists the lines: " << error;
  EXPECT_NE(error.find("4 (unnamed)"), std::string::npos) << error;

  config.start_button = Line(kLabel, "8");
  EXPECT_FALSE(gpio.Open(config, &error));
  std::printf("offset beyond: %s\n", error.c_str());
  EXPECT_NE(error.find("offset 8"), std::string::npos) << error;
  EXPECT_NE(error.find("8 lines"), std::string::npos) << error;

  config.start_button = Line("calibd-missing", "start_button");
  EXPECT_FALSE(gpio.Open(config, &error));
  std::printf("missing chip: %s\n", error.c_str());
  EXPECT_NE(error.find("agent.gpio.start_button.chip"), std::string::npos) << error;
  EXPECT_NE(error.find("\"calibd-missing\""), std::string::npos) << error;
  EXPECT_NE(error.find(chip_ + " [" + kLabel + "]"), std::string::npos)
      << "lists the chips: " << error;

  // A failure after earlier lines were requested holds none of them.
  config.interlock = Line(kLabel, "interlock");
  EXPECT_FALSE(gpio.Open(config, &error));
  EXPECT_FALSE(gpio.has_interlock());
  GpioConfig interlock_only;
  interlock_only.interlock = Line(kLabel, "interlock");
  GpioLines other;
  EXPECT_TRUE(other.Open(interlock_only, &error)) << "left requested by the failed Open: " << error;
}

TEST_F(GpioVmTest, LineHeldByAnotherConsumerIsAClearError) {
  // Another program holds the lamp line.
  gpiod_chip* chip = gpiod_chip_open_by_label(kLabel);
  ASSERT_NE(chip, nullptr);
  gpiod_line* held = gpiod_chip_get_line(chip, kStatusLamp);
  ASSERT_NE(held, nullptr);
  ASSERT_EQ(gpiod_line_request_output(held, "other-tool", 0), 0);

  GpioConfig config;
  config.status_lamp = Line(kLabel, "status_lamp");
  GpioLines gpio;
  std::string error;
  EXPECT_FALSE(gpio.Open(config, &error));
  std::printf("busy: %s\n", error.c_str());
  EXPECT_NE(error.find("agent.gpio.status_lamp"), std::string::npos) << error;
  EXPECT_NE(error.find("busy"), std::string::npos) << error;
  EXPECT_NE(error.find("\"other-tool\""), std::string::npos) << error;
  gpiod_chip_close(chip);  // releases the line

  // Two calibd instances: the second is told the first has it.
  ASSERT_TRUE(gpio.Open(config, &error)) << error;
  GpioLines second;
  EXPECT_FALSE(second.Open(config, &error));
  EXPECT_NE(error.find("\"calibd\""), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
