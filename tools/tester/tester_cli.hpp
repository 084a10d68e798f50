#pragma once
/// \file
/// calibd-tester's command line: parsing (host-tested) and the commands, written against
/// UdsClient. main.cpp is ParseTesterArgs + RunTester.

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "calibd/drivers/isotp_channel.hpp"
#include "uds_client.hpp"

namespace calibd::tester {

/// Exit codes (also in the --help text).
enum ExitCode : int {
  kExitOk = 0,         ///< done; calibrate: verified or updated; verify: verified
  kExitFailure = 1,    ///< unexpected response, secret file unreadable, ...
  kExitUsage = 2,      ///< bad command line
  kExitRejected = 3,   ///< calibrate/verify: verdict rejected
  kExitAborted = 4,    ///< calibrate/verify: failed or aborted
  kExitNegative = 5,   ///< the ECU answered with a negative response
  kExitTimeout = 6,    ///< no response within P2 / P2*, or the routine outlived its limit
  kExitInterface = 7,  ///< the CAN interface is missing or down, or ISO-TP failed
  /// verify: the car's stored calibration is out of tolerance (the routine answered `updated`):
  /// not a pass; recalibrate and commit.
  kExitOutOfTolerance = 8,
};

struct TesterOptions {
  IsoTpConfig isotp;
  ClientTiming timing;
  std::string secret_file;        ///< --secret: unlock before commands that need it
  std::string command;            ///< session, unlock, calibrate, verify, results, stop, ...
  std::vector<std::string> args;  ///< the command's positional arguments
  bool static_mode = false;       ///< calibrate/verify --static
  int max_duration_s = 0;         ///< calibrate/verify --max-duration (0: the agent's limit)
  bool no_wait = false;           ///< calibrate/verify --no-wait
  bool clear = false;             ///< dtc --clear
  bool functional = false;        ///< raw / tester-present --functional
  bool quiet = false;             ///< no progress on stderr
  int poll_ms = 500;              ///< results polling period
};

extern const char* const kTesterHelp;

/// Parses argv (without argv[0]). False with `error` (one line, no program name) on a bad
/// option, value or command; `help` true for --help (nothing else is checked then).
bool ParseTesterArgs(const std::vector<std::string>& argv, TesterOptions* options, bool* help,
                     std::string* error);

/// Runs the parsed command: results on `out`, progress and errors on `err` (errors prefixed
/// "calibd-tester: "). Returns the exit code.
int RunTester(const TesterOptions& options, std::ostream& out, std::ostream& err);

}  // namespace calibd::tester
