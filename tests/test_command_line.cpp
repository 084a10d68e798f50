// The tools' command lines (tools/common/command_line.hpp): flags and valued options in any order,
// lists of numbers, `--option=VALUE` where a tool takes it, and each kind of bad argument named as
// the tools print it.

#include "command_line.hpp"

#include <gtest/gtest.h>

#include <sstream>
#include <string>
#include <vector>

namespace calibd::tools {
namespace {

// argv for `args` (the program name first).
struct Argv {
  explicit Argv(std::vector<std::string> args) : strings(std::move(args)) {
    strings.insert(strings.begin(), "tool");
    for (auto& s : strings) pointers.push_back(s.data());
  }
  int argc() const { return static_cast<int>(pointers.size()); }
  char** argv() { return pointers.data(); }
  std::vector<std::string> strings;
  std::vector<char*> pointers;
};

struct Parsed {
  bool quiet = false, planes = false;
  std::string folder, name;
  long frames = 0;
  int p2 = 0;
  double ms = 0.0;
  std::vector<double> distance, mount;
  std::vector<long> loops;
  std::string error;
};

enum class Inline { kNo, kYes };

// A tool with one option of each kind; `inline_values`: it also takes --option=VALUE.
Parsed Parse(std::vector<std::string> args, Inline inline_values = Inline::kNo) {
  Argv a(std::move(args));
  CommandLine line("tool", a.argc(), a.argv());
  if (inline_values == Inline::kYes) line.AcceptInlineValues();
  Parsed p;
  while (line.Next()) {
    if (line.Is("--quiet"))
      p.quiet = true;
    else if (line.Is("--folder"))
      line.Value(&p.folder);
    else if (line.Is("--planes"))
      line.OnOff(&p.planes);
    else if (line.Is("--frames"))
      line.Integer(1, 100, &p.frames);
    else if (line.Is("--ms"))
      line.Number(0.0, 1000.0, &p.ms);
    else if (line.Is("--p2"))
      line.Integer(1, 600000, &p.p2, "ms");
    else if (line.Is("--name"))
      line.Text(&p.name);
    else if (line.Is("--distance"))
      line.Numbers({2, 2}, &p.distance);
    else if (line.Is("--mount"))
      line.Numbers({1, 6}, &p.mount);
    else if (line.Is("--loops"))
      line.Integers(Count{1}, 1, 1000, &p.loops);
    else
      line.Unknown();
  }
  if (line.failed()) {
    std::ostringstream err;
    EXPECT_EQ(line.Fail(err), kExitBadOption);
    p.error = err.str();
  }
  return p;
}

TEST(CommandLineTest, FlagsAndValuesInAnyOrder) {
  const Parsed p =
      Parse({"--ms", "12.5", "--quiet", "--folder", "d ir", "--planes", "on", "--frames", "100"});
  EXPECT_EQ(p.error, "");
  EXPECT_TRUE(p.quiet);
  EXPECT_EQ(p.folder, "d ir");
  EXPECT_TRUE(p.planes);
  EXPECT_EQ(p.frames, 100);
  EXPECT_DOUBLE_EQ(p.ms, 12.5);
  EXPECT_EQ(Parse({}).error, "");
}

TEST(CommandLineTest, EachBadArgumentIsNamedAndStopsTheParse) {
  EXPECT_EQ(Parse({"--folder"}).error, "tool: option --folder needs a value (see --help)\n");
  EXPECT_EQ(Parse({"--planes", "yes"}).error, "tool: --planes must be on or off (got 'yes')\n");
  EXPECT_EQ(Parse({"--frames", "0"}).error,
            "tool: --frames must be an integer in [1, 100] (got '0')\n");
  EXPECT_EQ(Parse({"--frames", "7x"}).error,
            "tool: --frames must be an integer in [1, 100] (got '7x')\n");
  EXPECT_EQ(Parse({"--frames", ""}).error,
            "tool: --frames must be an integer in [1, 100] (got '')\n");
  EXPECT_EQ(Parse({"--ms", "nan"}).error, "tool: --ms must be a number in [0, 1000] (got 'nan')\n");
  EXPECT_EQ(Parse({"--ms", "1e9"}).error, "tool: --ms must be a number in [0, 1000] (got '1e9')\n");
  EXPECT_EQ(Parse({"--bogus", "--quiet"}).error, "tool: unknown option '--bogus' (see --help)\n");
  // The parse stops at the first error: what follows is not read.
  const Parsed p = Parse({"--frames", "0", "--quiet"});
  EXPECT_FALSE(p.quiet);
}

TEST(CommandLineTest, ListsOfNumbersWithTheirCount) {
  const Parsed p = Parse({"--distance", "6,30", "--mount", "1.2,0,-1.95", "--loops", "1,10,1000"});
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(p.distance, (std::vector<double>{6.0, 30.0}));
  EXPECT_EQ(p.mount, (std::vector<double>{1.2, 0.0, -1.95}));
  EXPECT_EQ(p.loops, (std::vector<long>{1, 10, 1000}));
  EXPECT_EQ(Parse({"--distance", "6"}).error,
            "tool: --distance must be 2 comma-separated numbers (got '6')\n");
  EXPECT_EQ(Parse({"--distance", "6,30,9"}).error,
            "tool: --distance must be 2 comma-separated numbers (got '6,30,9')\n");
  EXPECT_EQ(Parse({"--mount", "1,2,3,4,5,6,7"}).error,
            "tool: --mount must be 1 to 6 comma-separated numbers (got '1,2,3,4,5,6,7')\n");
  // Empty items, words and non-finite numbers are no numbers.
  EXPECT_EQ(Parse({"--distance", "6,"}).error,
            "tool: --distance must be 2 comma-separated numbers (got '6,')\n");
  EXPECT_NE(Parse({"--distance", "6,x"}).error, "");
  EXPECT_NE(Parse({"--distance", "6,inf"}).error, "");
  EXPECT_NE(Parse({"--mount", ""}).error, "");
  EXPECT_EQ(Parse({"--loops", "1,0"}).error,
            "tool: --loops must be 1 or more comma-separated integers in [1, 1000] (got '1,0')\n");
  EXPECT_NE(Parse({"--loops", "1.5"}).error, "");
  EXPECT_EQ(Parse({"--loops"}).error, "tool: option --loops needs a value (see --help)\n");
}

TEST(CommandLineTest, TextUnitsAndIntsNameTheOptionAndValue) {
  const Parsed p = Parse({"--p2", "2000", "--name", "front"});
  EXPECT_EQ(p.p2, 2000);
  EXPECT_EQ(p.name, "front");
  EXPECT_EQ(Parse({"--p2", "0"}).error,
            "tool: --p2 must be an integer in [1, 600000] ms (got '0')\n");
  EXPECT_EQ(Parse({"--name", ""}).error, "tool: --name must be a non-empty value (got '')\n");
  EXPECT_EQ(Parse({"--folder", ""}).error, "");  // a plain value may be empty
}

TEST(CommandLineTest, InlineValuesOnlyWhereTheToolTakesThem) {
  const Parsed p =
      Parse({"--frames=7", "--distance=6,30", "--name=a=b", "--quiet", "--ms", "1"}, Inline::kYes);
  EXPECT_EQ(p.error, "");
  EXPECT_EQ(p.frames, 7);
  EXPECT_EQ(p.distance, (std::vector<double>{6.0, 30.0}));
  EXPECT_EQ(p.name, "a=b");  // split at the first '='
  EXPECT_TRUE(p.quiet);
  EXPECT_DOUBLE_EQ(p.ms, 1.0);
  // The value after '=' is checked as any other, and named with the option.
  EXPECT_EQ(Parse({"--frames=0"}, Inline::kYes).error,
            "tool: --frames must be an integer in [1, 100] (got '0')\n");
  EXPECT_EQ(Parse({"--distance=6"}, Inline::kYes).error,
            "tool: --distance must be 2 comma-separated numbers (got '6')\n");
  EXPECT_EQ(Parse({"--name="}, Inline::kYes).error,
            "tool: --name must be a non-empty value (got '')\n");
  EXPECT_EQ(Parse({"--bogus=1"}, Inline::kYes).error,
            "tool: unknown option '--bogus' (see --help)\n");
  // A flag takes no value, also as the last argument.
  EXPECT_EQ(Parse({"--quiet=1", "--frames", "2"}, Inline::kYes).error,
            "tool: option --quiet takes no value (got '--quiet=1')\n");
  EXPECT_EQ(Parse({"--quiet=yes"}, Inline::kYes).error,
            "tool: option --quiet takes no value (got '--quiet=yes')\n");
  // Where the tool does not take them, the whole argument is the option.
  EXPECT_EQ(Parse({"--frames=7"}).error, "tool: unknown option '--frames=7' (see --help)\n");
}

TEST(CommandLineTest, ArgumentsFromAVectorAndPositionals) {
  CommandLine line("tester", std::vector<std::string>{"-", "--x", "raw"});
  ASSERT_TRUE(line.Next());
  EXPECT_FALSE(line.IsOption());  // a lone '-' is an argument
  ASSERT_TRUE(line.Next());
  EXPECT_TRUE(line.IsOption());
  ASSERT_TRUE(line.Next());
  EXPECT_EQ(line.arg(), "raw");
  EXPECT_FALSE(line.IsOption());
  EXPECT_FALSE(line.Next());
  EXPECT_FALSE(line.failed());
}

TEST(CommandLineTest, SplitListKeepsEmptyItems) {
  EXPECT_EQ(SplitList("ot128,m1"), (std::vector<std::string>{"ot128", "m1"}));
  EXPECT_EQ(SplitList("a,,b"), (std::vector<std::string>{"a", "", "b"}));
  EXPECT_EQ(SplitList(""), (std::vector<std::string>{""}));
}

}  // namespace
}  // namespace calibd::tools
