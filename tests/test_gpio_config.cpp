// GpioConfig validation and the line-as-offset rule (drivers/gpio_lines.hpp); GpioLines on a
// host without the configured chip fails with an error naming it. The real chip: tests/vm/.

#include <gtest/gtest.h>

#include <string>

#include "calibd/drivers/gpio_lines.hpp"

namespace calibd {
namespace {

GpioLineConfig Line(std::string chip, std::string line, bool active_low = false) {
  GpioLineConfig c;
  c.chip = std::move(chip);
  c.line = std::move(line);
  c.active_low = active_low;
  c.enabled = true;
  return c;
}

TEST(GpioConfigTest, DefaultsAreAllDisabledAndValid) {
  const GpioConfig config;
  EXPECT_FALSE(config.interlock.enabled);
  EXPECT_FALSE(config.start_button.enabled);
  EXPECT_FALSE(config.status_lamp.enabled);
  EXPECT_FALSE(config.start_button.active_low);
  EXPECT_EQ(config.start_button_debounce_ms, 30);
  std::string error;
  EXPECT_TRUE(config.IsValid(&error)) << error;
}

TEST(GpioConfigTest, LineAsOffsetOrName) {
  EXPECT_EQ(ParseGpioLineOffset("0"), 0u);
  EXPECT_EQ(ParseGpioLineOffset("7"), 7u);
  EXPECT_EQ(ParseGpioLineOffset("0012"), 12u);
  EXPECT_EQ(ParseGpioLineOffset("2147483647"), 2147483647u);
  EXPECT_FALSE(ParseGpioLineOffset("2147483648").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("99999999999999999999").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("start_button").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("3a").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("-1").has_value());
  EXPECT_FALSE(ParseGpioLineOffset(" 1").has_value());
  EXPECT_FALSE(ParseGpioLineOffset("+1").has_value());
}

TEST(GpioConfigTest, EnabledLinesByNameAndByOffsetAreValid) {
  GpioConfig config;
  config.interlock = Line("calibd-sim", "interlock");
  config.start_button = Line("gpiochip0", "1", /*active_low=*/true);
  config.status_lamp = Line("/dev/gpiochip0", "status_lamp");
  std::string error;
  EXPECT_TRUE(config.IsValid(&error)) << error;
}

TEST(GpioConfigTest, EnabledLineNeedsChipAndLine) {
  std::string error;
  GpioConfig config;
  config.start_button = Line("", "start_button");
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("agent.gpio.start_button.chip"), std::string::npos) << error;

  config.start_button = Line("calibd-sim", "");
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("agent.gpio.start_button.line"), std::string::npos) << error;

  // A disabled line's keys are not checked.
  config.start_button.enabled = false;
  EXPECT_TRUE(config.IsValid(&error)) << error;
}

TEST(GpioConfigTest, OffsetOutOfRangeNamesTheKey) {
  GpioConfig config;
  config.status_lamp = Line("calibd-sim", "99999999999");
  std::string error;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("agent.gpio.status_lamp.line"), std::string::npos) << error;
  EXPECT_NE(error.find("out of range"), std::string::npos) << error;
}

TEST(GpioConfigTest, SameLineTwiceIsRefused) {
  GpioConfig config;
  config.interlock = Line("calibd-sim", "2");
  config.status_lamp = Line("calibd-sim", "2");
  std::string error;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("agent.gpio.status_lamp"), std::string::npos) << error;
  EXPECT_NE(error.find("agent.gpio.interlock"), std::string::npos) << error;
  // Disabled: no conflict.
  config.interlock.enabled = false;
  EXPECT_TRUE(config.IsValid(&error)) << error;
}

TEST(GpioConfigTest, DebounceRange) {
  GpioConfig config;
  std::string error;
  config.start_button_debounce_ms = 0;
  EXPECT_TRUE(config.IsValid(&error)) << error;
  config.start_button_debounce_ms = GpioConfig::kMaxDebounceMs;
  EXPECT_TRUE(config.IsValid(&error)) << error;
  config.start_button_debounce_ms = -1;
  EXPECT_FALSE(config.IsValid(&error));
  EXPECT_NE(error.find("agent.gpio.start_button_debounce_ms"), std::string::npos) << error;
  config.start_button_debounce_ms = GpioConfig::kMaxDebounceMs + 1;
  EXPECT_FALSE(config.IsValid(&error));
}

TEST(GpioLinesTest, NothingEnabledOpensWithoutAnyChip) {
  GpioLines gpio;
  std::string error;
  ASSERT_TRUE(gpio.Open(GpioConfig{}, &error)) << error;
  EXPECT_FALSE(gpio.has_interlock());
  EXPECT_FALSE(gpio.has_start_button());
  EXPECT_FALSE(gpio.has_status_lamp());
  EXPECT_EQ(gpio.event_fd(), -1);
  EXPECT_TRUE(gpio.interlock());  // no interlock fitted: nothing restricts calibration
  EXPECT_FALSE(gpio.HandleEvents(1000000));
  EXPECT_FALSE(gpio.debounce_deadline_us().has_value());
  gpio.SetLampState(LampState::kRunning, 0);
  gpio.UpdateLamp(0);
  EXPECT_EQ(gpio.lamp_writes(), 0);
}

TEST(GpioLinesTest, MissingChipIsNamedInTheError) {
  GpioConfig config;
  config.interlock = Line("calibd-no-such-chip", "interlock");
  GpioLines gpio;
  std::string error;
  EXPECT_FALSE(gpio.Open(config, &error));
  EXPECT_NE(error.find("agent.gpio.interlock.chip"), std::string::npos) << error;
  EXPECT_NE(error.find("calibd-no-such-chip"), std::string::npos) << error;
  EXPECT_NE(error.find("chips present"), std::string::npos) << error;
  EXPECT_FALSE(gpio.has_interlock());
}

TEST(GpioLinesTest, InvalidConfigIsRefusedBeforeAnyChip) {
  GpioConfig config;
  config.start_button = Line("calibd-sim", "start_button");
  config.start_button_debounce_ms = 5000;
  GpioLines gpio;
  std::string error;
  EXPECT_FALSE(gpio.Open(config, &error));
  EXPECT_NE(error.find("start_button_debounce_ms"), std::string::npos) << error;
}

}  // namespace
}  // namespace calibd
