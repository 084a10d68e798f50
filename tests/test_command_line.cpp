// The offline tools' command lines (tools/common/command_line.hpp): flags and valued options in
// any order, and each kind of bad argument named as the tools print it.

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
  std::string folder;
  long frames = 0;
  double ms = 0.0;
  std::string error;
};

// A tool with one option of each kind.
Parsed Parse(std::vector<std::string> args) {
  Argv a(std::move(args));
  CommandLine line("tool", a.argc(), a.argv());
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

}  // namespace
}  // namespace calibd::tools
