// calibd-tester: the workshop's diagnostic tester for calibd over CAN (UDS on ISO-TP): session,
// security unlock, calibrate with progress, commit, DIDs, DTCs. See --help (tester_cli.cpp).

#include <iostream>
#include <string>
#include <vector>

#include "tester_cli.hpp"

int main(int argc, char** argv) {
  using namespace calibd::tester;
  const std::vector<std::string> args(argv + 1, argv + argc);
  TesterOptions options;
  bool help = false;
  std::string error;
  if (!ParseTesterArgs(args, &options, &help, &error)) {
    std::cerr << "calibd-tester: " << error << "\n";
    return kExitUsage;
  }
  if (help) {
    std::cout << kTesterHelp;
    return kExitOk;
  }
  return RunTester(options, std::cout, std::cerr);
}
