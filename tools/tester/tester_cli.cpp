#include "tester_cli.hpp"

#include <poll.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <ostream>

#include "calibd/agent/uds/did_codec.hpp"
#include "calibd/agent/uds/routines.hpp"
#include "calibd/agent/uds/security_access.hpp"
#include "calibd/agent/uds/uds_types.hpp"
#include "command_line.hpp"
#include "uds_decode.hpp"

namespace calibd::tester {

const char* const kTesterHelp =
    R"(calibd-tester: workshop diagnostic tester for calibd (UDS, ISO 14229-1, on ISO-TP/CAN).

Usage: calibd-tester [options] <command> [command options]

Commands:
  session default|extended   change the diagnostic session
  unlock                     extended session + SecurityAccess 0x27 01/02 (needs --secret)
  calibrate [--static] [--max-duration S] [--no-wait]
                             start routine 0xF0A0 and follow it (results every 500 ms, progress
                             and where boards are still missing on stderr) until its verdict;
                             needs --secret unless already unlocked
  verify [--static] [--max-duration S] [--no-wait]
                             as calibrate with routine 0xF0A3 (never changes the calibration)
  results [verify]           one requestRoutineResults of calibrate (or verify)
  stop                       stop the running calibrate/verify routine
  commit                     commit the last updated result (routine 0xF0A1)
  restore-reference          make the factory reference current (routine 0xF0A2)
  store-reference            keep the current calibration as the reference: the end-of-line
                             step after its commit (routine 0xF0A4)
  read DID[,DID...]          ReadDataByIdentifier, decoded (F18C F190 F195 F19B FD00-FD06)
  coverage                   where boards are still missing in the running session: distance
                             bins, the image grid and what to do next (DID FD06)
  write-vin VIN              WriteDataByIdentifier 0xF190 (extended session, unlocked)
  dtc [--clear]              read the DTCs (0x19 02 mask 0xFF) with their status bits, or clear
                             them (0x14 FFFFFF)
  tester-present [--functional]
                             TesterPresent 0x3E 00 (physical, or functional on the 0x7DF id)
  raw HEX [--functional]     send bytes (e.g. "22 F1 90"), print the response in hex

Options:
  --interface NAME     CAN interface (default can0)
  --ids REQ,RSP,FUNC   physical request, physical response and functional ids in hex
                       (default 7E0,7E8,7DF)
  --extended-ids       29-bit identifiers
  --can-fd             CAN FD frames (the interface needs MTU 72)
  --secret FILE        the vehicle's SecurityAccess secret (mode 0600): unlock before commands
                       that change the ECU (calibrate, verify, stop, commit, restore-reference,
                       store-reference, write-vin). Each run opens its own extended session; the ECU drops it (and
                       relocks) 5 s after the last request.
  --p2-ms MS           wait for a response (default 200)
  --p2-star-ms MS      wait after a 0x78 responsePending (default 5500)
  --quiet              no progress on stderr
  --help               this text

Exit codes: 0 done (calibrate: verified or updated; verify: verified), 1 other failure, 2 bad
command line, 3 rejected, 4 failed or aborted, 5 negative response from the ECU, 6 timeout, 7 CAN
interface missing or down, or an ISO-TP transfer failed, 8 verify: out of tolerance (the stored
calibration differs from the measurement; recalibrate and commit).
)";

namespace {

constexpr const char* kPrefix = "calibd-tester: ";
// The routine's progress (results byte 1) stays below this while the session collects; the
// solve reports 90 % (SessionMachine::progress).
constexpr int kSolvingPercent = 90;

bool ParseHexId(const std::string& text, uint32_t* id) {
  std::string digits = text;
  if (digits.size() > 2 && digits[0] == '0' && (digits[1] == 'x' || digits[1] == 'X'))
    digits = digits.substr(2);
  if (digits.empty() || digits.size() > 8) return false;
  char* end = nullptr;
  const unsigned long v = std::strtoul(digits.c_str(), &end, 16);
  if (*end != '\0') return false;
  *id = static_cast<uint32_t>(v);
  return true;
}

// --ids REQ,RSP,FUNC into `isotp`; the error in `line` when they are not three hex ids.
void ReadIds(const std::string& value, tools::CommandLine* line, IsoTpConfig* isotp) {
  const std::vector<std::string> ids = tools::SplitList(value);
  uint32_t v[3] = {};
  if (ids.size() != 3 || !ParseHexId(ids[0], &v[0]) || !ParseHexId(ids[1], &v[1]) ||
      !ParseHexId(ids[2], &v[2])) {
    line->Error("--ids takes three hex ids REQ,RSP,FUNC, e.g. 7E0,7E8,7DF (got '" + value + "')");
    return;
  }
  isotp->physical_request_id = v[0];
  isotp->physical_response_id = v[1];
  isotp->functional_request_id = v[2];
}

bool IsRoutineCommand(const std::string& c) { return c == "calibrate" || c == "verify"; }

/// One request with its error reporting; returns kExitOk with the positive response in `reply`.
int Call(UdsClient& client, const std::vector<uint8_t>& request, std::ostream& err, UdsReply* reply,
         bool functional = false) {
  *reply = client.Request(request, functional);
  const uint8_t sid = request[0];
  switch (reply->outcome) {
    case UdsReply::Outcome::kPositive:
    case UdsReply::Outcome::kNoResponse:
      return kExitOk;
    case UdsReply::Outcome::kNegative:
      err << kPrefix << DescribeNegativeResponse(sid, reply->nrc) << "\n";
      return kExitNegative;
    case UdsReply::Outcome::kTimeout:
      err << kPrefix << "no response to " << client.Describe(sid) << " within " << reply->waited_ms
          << " ms";
      if (reply->pending_count > 0)
        err << " (" << reply->pending_count << " responsePending, then P2* "
            << client.timing().p2_star_ms << " ms)";
      else
        err << " (P2 " << client.timing().p2_ms << " ms)";
      err << ": is calibd running, and are the interface and --ids right?\n";
      return kExitTimeout;
    case UdsReply::Outcome::kLinkDown:
      err << kPrefix << client.Describe(sid) << " failed: the interface is down or gone ("
          << reply->error << ")\n";
      return kExitInterface;
    case UdsReply::Outcome::kTransportError:
      err << kPrefix << client.Describe(sid) << " failed in ISO-TP: " << reply->error << "\n";
      return kExitInterface;
  }
  return kExitFailure;
}

/// Checks a positive response's length; prints what is wrong.
bool ExpectSize(const UdsReply& reply, size_t min_size, std::ostream& err) {
  if (reply.bytes.size() >= min_size) return true;
  err << kPrefix << "malformed response " << FormatHex(reply.bytes.data(), reply.bytes.size())
      << " (expected at least " << min_size << " bytes)\n";
  return false;
}

int EnterSession(UdsClient& client, uint8_t session, std::ostream& out, std::ostream& err,
                 bool print) {
  UdsReply reply;
  const int code = Call(client, {uds::kSidDiagnosticSessionControl, session}, err, &reply);
  if (code != kExitOk) return code;
  if (!ExpectSize(reply, 6, err)) return kExitFailure;
  if (print) {
    const int p2 = (reply.bytes[2] << 8) | reply.bytes[3];
    const int p2_star = ((reply.bytes[4] << 8) | reply.bytes[5]) * 10;
    out << "session " << (session == 0x03 ? "extended" : "default") << " (P2 " << p2 << " ms, P2* "
        << p2_star << " ms)\n";
  }
  return kExitOk;
}

int Unlock(UdsClient& client, const std::string& secret_file, std::ostream& out,
           std::ostream& err) {
  std::string secret, error;
  if (!uds::LoadSecret(secret_file, &secret, &error)) {
    err << kPrefix << "cannot use the secret: " << error << "\n";
    return kExitFailure;
  }
  UdsReply reply;
  int code = Call(client, {uds::kSidSecurityAccess, 0x01}, err, &reply);
  if (code != kExitOk) return code;
  if (!ExpectSize(reply, 2 + uds::kSeedSize, err)) return kExitFailure;
  const uint8_t* seed = reply.bytes.data() + 2;
  bool zero = true;
  for (size_t i = 0; i < uds::kSeedSize; ++i) zero = zero && seed[i] == 0;
  if (zero) {  // ISO 14229-1 §9.4.2.2: an unlocked ECU answers an all-zero seed
    out << "already unlocked\n";
    return kExitOk;
  }
  uint8_t key[uds::kKeySize];
  if (!uds::ComputeKey(secret, seed, uds::kSeedSize, key)) {
    err << kPrefix << "HMAC-SHA256 of the seed failed (OpenSSL)\n";
    return kExitFailure;
  }
  std::vector<uint8_t> send_key(2 + uds::kKeySize);
  send_key[0] = uds::kSidSecurityAccess;
  send_key[1] = 0x02;
  std::copy(key, key + uds::kKeySize, send_key.begin() + 2);
  code = Call(client, send_key, err, &reply);
  if (code != kExitOk) return code;
  out << "unlocked\n";
  return kExitOk;
}

std::vector<uint8_t> RoutineRequest(uint8_t type, uint16_t rid) {
  return {uds::kSidRoutineControl, type, static_cast<uint8_t>(rid >> 8),
          static_cast<uint8_t>(rid & 0xFF)};
}

struct Results {
  uint8_t status = 0, progress = 0, verdict = 0, reason = 0;
  double rotation_deg = 0, translation_mm = 0;
};

int ReadResults(UdsClient& client, uint16_t rid, std::ostream& err, Results* r) {
  UdsReply reply;
  const int code = Call(client, RoutineRequest(uds::kRequestRoutineResults, rid), err, &reply);
  if (code != kExitOk) return code;
  if (!ExpectSize(reply, 4 + uds::kCalibrationResultSize, err)) return kExitFailure;
  const uint8_t* p = reply.bytes.data() + 4;
  r->status = p[0];
  r->progress = p[1];
  r->verdict = p[2];
  r->reason = p[3];
  r->rotation_deg = ((p[4] << 8) | p[5]) * uds::kRotationFigureLsbDeg;
  r->translation_mm = ((p[6] << 8) | p[7]) * uds::kLengthFigureLsbM * 1000.0;
  return kExitOk;
}

void PrintResults(const Results& r, std::ostream& out) {
  char line[160];
  std::snprintf(line, sizeof(line),
                "status: %s\nprogress: %d%%\nverdict: %s\nreason: %s\nrotation delta: %.3f deg\n"
                "translation delta: %.1f mm\n",
                RoutineStatusName(r.status), r.progress, RoutineVerdictName(r.verdict),
                RoutineReasonName(r.reason), r.rotation_deg, r.translation_mm);
  out << line;
}

/// Exit code of a finished routine. `updated` from verify is no pass: the stored calibration is
/// out of tolerance (and verify's result cannot be committed).
int VerdictExit(const Results& r, bool verify) {
  if (r.status == static_cast<uint8_t>(uds::RoutineStatus::kSuccess)) {
    if (r.verdict == static_cast<uint8_t>(uds::RoutineVerdict::kVerified)) return kExitOk;
    if (r.verdict == static_cast<uint8_t>(uds::RoutineVerdict::kUpdated))
      return verify ? kExitOutOfTolerance : kExitOk;
    if (r.verdict == static_cast<uint8_t>(uds::RoutineVerdict::kRejected)) return kExitRejected;
  }
  return kExitAborted;
}

/// What to do after an `updated`: commit a calibration's; recalibrate after a verify's.
void PrintNextStep(const Results& r, bool verify, std::ostream& out) {
  if (r.status != static_cast<uint8_t>(uds::RoutineStatus::kSuccess) ||
      r.verdict != static_cast<uint8_t>(uds::RoutineVerdict::kUpdated))
    return;
  if (verify)
    out << "out of tolerance: the stored calibration differs from this measurement; recalibrate "
           "with: calibd-tester --secret FILE calibrate, then commit\n";
  else
    out << "commit it with: calibd-tester --secret FILE commit\n";
}

void ShowProgress(const Results& r, bool tty, int* last_shown, std::ostream& err) {
  if (tty) {
    const int filled = r.progress / 5;
    err << "\r[" << std::string(static_cast<size_t>(filled), '#')
        << std::string(static_cast<size_t>(20 - filled), '.') << "] " << int{r.progress} << "% "
        << RoutineStatusName(r.status) << "   " << std::flush;
  } else if (r.progress / 10 != *last_shown / 10 || *last_shown < 0) {
    err << "progress " << int{r.progress} << "% " << RoutineStatusName(r.status) << "\n";
  }
  *last_shown = r.progress;
}

// Reads DID 0xFD06; errors go to `err`.
int ReadCoverage(UdsClient& client, CaptureCoverage* coverage, std::ostream& err) {
  UdsReply reply;
  const int code = Call(client,
                        {uds::kSidReadDataByIdentifier, uds::kDidCaptureCoverage >> 8,
                         uds::kDidCaptureCoverage & 0xFF},
                        err, &reply);
  if (code != kExitOk) return code;
  if (!ExpectSize(reply, 3 + uds::kCoverageSize, err)) return kExitFailure;
  *coverage = uds::DecodeCoverage(reply.bytes.data() + 3);
  return kExitOk;
}

int RunRoutine(UdsClient& client, const TesterOptions& o, std::ostream& out, std::ostream& err) {
  const uint16_t rid = o.command == "verify" ? uds::kRoutineVerify : uds::kRoutineCalibrate;
  std::vector<uint8_t> start = RoutineRequest(uds::kStartRoutine, rid);
  start.push_back(o.static_mode ? 0x01 : 0x00);
  start.push_back(static_cast<uint8_t>(o.max_duration_s >> 8));
  start.push_back(static_cast<uint8_t>(o.max_duration_s & 0xFF));
  UdsReply reply;
  int code = Call(client, start, err, &reply);
  if (code != kExitOk) return code;
  if (o.no_wait) {
    out << o.command << " started (follow it with: calibd-tester results"
        << (rid == uds::kRoutineVerify ? " verify" : "") << ")\n";
    return kExitOk;
  }
  // The agent's own limit applies when max_duration_s is 0; it is at most 3600 s. The grace
  // covers solving after collection.
  const int limit_s = (o.max_duration_s > 0 ? o.max_duration_s : uds::kMaxCalibrationDurationS);
  const int64_t deadline_us = MonotonicUs() + (int64_t{limit_s} + 120) * 1000000;
  const bool tty = !o.quiet && ::isatty(STDERR_FILENO);
  int last_shown = -1;
  // Capture guidance while collecting (DID 0xFD06), printed when it changes; an agent without
  // the DID is followed without it.
  bool coverage_available = true;
  std::string guidance, last_guidance;
  Results r;
  for (;;) {
    code = ReadResults(client, rid, err, &r);
    if (code != kExitOk) {
      if (tty) err << "\n";
      return code;
    }
    if (!o.quiet) ShowProgress(r, tty, &last_shown, err);
    if (r.status != static_cast<uint8_t>(uds::RoutineStatus::kActive)) break;
    if (!o.quiet && coverage_available) {
      CaptureCoverage coverage;
      std::ostream quiet(nullptr);  // an agent without the DID is followed without it
      coverage_available = ReadCoverage(client, &coverage, quiet) == kExitOk;
      if (coverage_available && r.progress < kSolvingPercent) {
        guidance.clear();
        AppendCaptureGuidance(coverage, &guidance);
        if (guidance != last_guidance) {
          err << (tty ? "\n" : "") << "next: " << guidance << "\n";
          last_guidance = guidance;
        }
      }
    }
    if (MonotonicUs() > deadline_us) {
      if (tty) err << "\n";
      err << kPrefix << "the routine is still active " << limit_s + 120
          << " s after its start; stop it with: calibd-tester stop\n";
      return kExitTimeout;
    }
    // Between polls: TesterPresent if the polls ever space out beyond its period (S3 is 5 s).
    const int64_t next_us = MonotonicUs() + int64_t{o.poll_ms} * 1000;
    while (MonotonicUs() < next_us) {
      client.KeepAlive();
      ::poll(nullptr, 0, 20);
    }
  }
  if (tty) err << "\n";
  PrintResults(r, out);
  PrintNextStep(r, rid == uds::kRoutineVerify, out);
  return VerdictExit(r, rid == uds::kRoutineVerify);
}

int RunRead(UdsClient& client, const TesterOptions& o, std::ostream& out, std::ostream& err) {
  std::vector<uint8_t> request = {uds::kSidReadDataByIdentifier};
  for (const std::string& text : tools::SplitList(o.args[0])) {
    uint16_t did = 0;
    ParseDid(text, &did);  // checked by ParseTesterArgs
    request.push_back(static_cast<uint8_t>(did >> 8));
    request.push_back(static_cast<uint8_t>(did & 0xFF));
  }
  UdsReply reply;
  const int code = Call(client, request, err, &reply);
  if (code != kExitOk) return code;
  const std::vector<uint8_t>& b = reply.bytes;
  size_t pos = 1;
  while (pos + 2 <= b.size()) {
    const uint16_t did = static_cast<uint16_t>((b[pos] << 8) | b[pos + 1]);
    const size_t size = DidSize(did);
    char head[16];
    std::snprintf(head, sizeof(head), "%04X", did);
    if (size == 0 || pos + 2 + size > b.size()) {
      err << kPrefix << "cannot decode DID " << head
          << " in the response; the rest: " << FormatHex(b.data() + pos, b.size() - pos) << "\n";
      return kExitFailure;
    }
    out << head << " " << DidName(did) << ": " << DecodeDid(did, b.data() + pos + 2, size) << "\n";
    pos += 2 + size;
  }
  return kExitOk;
}

int RunDtc(UdsClient& client, const TesterOptions& o, std::ostream& out, std::ostream& err) {
  UdsReply reply;
  if (o.clear) {
    const int code =
        Call(client, {uds::kSidClearDiagnosticInformation, 0xFF, 0xFF, 0xFF}, err, &reply);
    if (code == kExitOk) out << "DTCs cleared\n";
    return code;
  }
  const int code = Call(client, {uds::kSidReadDtcInformation, 0x02, 0xFF}, err, &reply);
  if (code != kExitOk) return code;
  if (!ExpectSize(reply, 3, err)) return kExitFailure;
  const std::vector<uint8_t>& b = reply.bytes;
  int count = 0;
  for (size_t pos = 3; pos + 4 <= b.size(); pos += 4, ++count) {
    const uint32_t number = (uint32_t{b[pos]} << 16) | (uint32_t{b[pos + 1]} << 8) | b[pos + 2];
    char line[64];
    std::snprintf(line, sizeof(line), "%s (0x%06X) ", FormatDtc(number).c_str(), number);
    char status[8];
    std::snprintf(status, sizeof(status), "0x%02X", b[pos + 3]);
    out << line << DtcName(number) << ": status " << status << " (" << DescribeDtcStatus(b[pos + 3])
        << ")\n";
  }
  if (count == 0) out << "no DTC\n";
  return kExitOk;
}

int RunCommand(UdsClient& client, const TesterOptions& o, std::ostream& out, std::ostream& err) {
  const std::string& c = o.command;
  UdsReply reply;
  if (c == "session")
    return EnterSession(client, o.args[0] == "extended" ? 0x03 : 0x01, out, err, true);
  if (c == "read") return RunRead(client, o, out, err);
  if (c == "coverage") {
    CaptureCoverage coverage;
    const int code = ReadCoverage(client, &coverage, err);
    if (code == kExitOk) out << CoverageChart(coverage);
    return code;
  }
  if (c == "dtc") return RunDtc(client, o, out, err);
  if (c == "tester-present") {
    const int code = Call(client, {uds::kSidTesterPresent, 0x00}, err, &reply, o.functional);
    if (code == kExitOk)
      out << "TesterPresent answered (" << FormatHex(reply.bytes.data(), reply.bytes.size())
          << ")\n";
    return code;
  }
  if (c == "raw") {
    std::string joined;
    for (const std::string& a : o.args) joined += a + " ";
    std::vector<uint8_t> request;
    ParseHex(joined, &request);  // checked by ParseTesterArgs
    const int code = Call(client, request, err, &reply, o.functional);
    if (!reply.bytes.empty()) out << FormatHex(reply.bytes.data(), reply.bytes.size()) << "\n";
    return code;
  }
  // Everything else needs the extended session (RoutineControl is not available in the default
  // one), and changing the ECU needs security: unlock when a secret is given.
  int code = EnterSession(client, 0x03, out, err, false);
  if (code != kExitOk) return code;
  if (!o.secret_file.empty()) {
    std::ostream& unlock_out = c == "unlock" ? out : err;
    if (c != "unlock" && o.quiet) {
      std::ostream null_stream(nullptr);
      code = Unlock(client, o.secret_file, null_stream, err);
    } else {
      code = Unlock(client, o.secret_file, unlock_out, err);
    }
    if (code != kExitOk) return code;
  }
  if (c == "unlock") return kExitOk;
  if (c == "results") {
    const bool verify = !o.args.empty();
    Results r;
    code = ReadResults(client, verify ? uds::kRoutineVerify : uds::kRoutineCalibrate, err, &r);
    if (code != kExitOk) return code;
    PrintResults(r, out);
    if (r.status == static_cast<uint8_t>(uds::RoutineStatus::kActive) ||
        r.status == static_cast<uint8_t>(uds::RoutineStatus::kIdle))
      return kExitOk;
    PrintNextStep(r, verify, out);
    return VerdictExit(r, verify);
  }

  if (IsRoutineCommand(c)) return RunRoutine(client, o, out, err);
  if (c == "stop") {
    code = Call(client, RoutineRequest(uds::kStopRoutine, uds::kRoutineCalibrate), err, &reply);
    if (code == kExitOk) out << "stopped\n";
    return code;
  }
  if (c == "commit" || c == "restore-reference" || c == "store-reference") {
    const uint16_t rid = c == "commit"              ? uds::kRoutineCommit
                         : c == "restore-reference" ? uds::kRoutineRestoreReference
                                                    : uds::kRoutineStoreReference;
    code = Call(client, RoutineRequest(uds::kStartRoutine, rid), err, &reply);
    if (code != kExitOk) return code;
    if (!ExpectSize(reply, 5, err)) return kExitFailure;
    out << c << ": " << RoutineStatusName(reply.bytes[4]) << "\n";
    return reply.bytes[4] == static_cast<uint8_t>(uds::RoutineStatus::kSuccess) ? kExitOk
                                                                                : kExitAborted;
  }
  if (c == "write-vin") {
    std::vector<uint8_t> request = {uds::kSidWriteDataByIdentifier, 0xF1, 0x90};
    request.insert(request.end(), o.args[0].begin(), o.args[0].end());
    code = Call(client, request, err, &reply);
    if (code == kExitOk) out << "VIN written: " << o.args[0] << "\n";
    return code;
  }
  err << kPrefix << "unknown command '" << c << "'\n";
  return kExitUsage;
}

}  // namespace

bool ParseTesterArgs(const std::vector<std::string>& argv, TesterOptions* o, bool* help,
                     std::string* error) {
  *help = false;
  bool have_max_duration = false;
  tools::CommandLine line("calibd-tester", argv);
  while (line.Next()) {
    std::string value;
    if (line.Is("--help") || line.Is("-h")) {
      *help = true;
      return true;
    } else if (line.Is("--extended-ids")) {
      o->isotp.extended_ids = true;
    } else if (line.Is("--can-fd")) {
      o->isotp.can_fd = true;
    } else if (line.Is("--quiet")) {
      o->quiet = true;
    } else if (line.Is("--static")) {
      o->static_mode = true;
    } else if (line.Is("--no-wait")) {
      o->no_wait = true;
    } else if (line.Is("--clear")) {
      o->clear = true;
    } else if (line.Is("--functional")) {
      o->functional = true;
    } else if (line.Is("--interface")) {
      line.Value(&o->isotp.interface);
    } else if (line.Is("--secret")) {
      line.Value(&o->secret_file);
    } else if (line.Is("--ids")) {
      if (line.Value(&value)) ReadIds(value, &line, &o->isotp);
    } else if (line.Is("--p2-ms")) {
      line.Integer(1, 600000, &o->timing.p2_ms, "ms");
    } else if (line.Is("--p2-star-ms")) {
      line.Integer(1, 600000, &o->timing.p2_star_ms, "ms");
    } else if (line.Is("--poll-ms")) {
      line.Integer(1, 600000, &o->poll_ms, "ms");
    } else if (line.Is("--max-duration")) {
      have_max_duration =
          line.Integer(1, uds::kMaxCalibrationDurationS, &o->max_duration_s, "seconds");
    } else if (line.IsOption() && o->command != "raw") {  // raw's request: checked below
      line.Unknown();
    } else if (o->command.empty()) {
      o->command = line.arg();
    } else {
      o->args.push_back(line.arg());
    }
  }
  if (line.failed()) {
    *error = line.error();
    return false;
  }

  const std::string& c = o->command;
  auto args_count = [&](size_t min, size_t max, const char* usage) {
    if (o->args.size() >= min && o->args.size() <= max) return true;
    *error = std::string("usage: calibd-tester ") + usage;
    return false;
  };
  if (c.empty()) {
    *error = "no command given (see --help)";
    return false;
  }
  if (c == "session") {
    if (!args_count(1, 1, "session default|extended")) return false;
    if (o->args[0] != "default" && o->args[0] != "extended") {
      *error = "session must be default or extended (got '" + o->args[0] + "')";
      return false;
    }
  } else if (c == "unlock") {
    if (!args_count(0, 0, "--secret FILE unlock")) return false;
    if (o->secret_file.empty()) {
      *error = "unlock needs --secret FILE (the vehicle's SecurityAccess secret)";
      return false;
    }
  } else if (IsRoutineCommand(c)) {
    if (!args_count(0, 0, "calibrate|verify [--static] [--max-duration S] [--no-wait]"))
      return false;
  } else if (c == "results") {
    if (!args_count(0, 1, "results [verify]")) return false;
    if (!o->args.empty() && o->args[0] != "verify") {
      *error = "results takes nothing or 'verify' (got '" + o->args[0] + "')";
      return false;
    }
  } else if (c == "stop" || c == "commit" || c == "restore-reference" || c == "store-reference" ||
             c == "tester-present" || c == "coverage") {
    if (!args_count(0, 0, (c + (c == "tester-present" ? " [--functional]" : "")).c_str()))
      return false;
  } else if (c == "dtc") {
    if (!args_count(0, 0, "dtc [--clear]")) return false;
  } else if (c == "read") {
    if (!args_count(1, 1, "read DID[,DID...] (hex, e.g. F190,FD00)")) return false;
    const std::vector<std::string> dids = tools::SplitList(o->args[0]);
    if (dids.size() > 16) {
      *error = "read takes at most 16 DIDs in one request";
      return false;
    }
    for (const std::string& d : dids) {
      uint16_t did = 0;
      if (!ParseDid(d, &did)) {
        *error = "'" + d + "' is not a DID (1-4 hex digits, e.g. F190)";
        return false;
      }
    }
  } else if (c == "write-vin") {
    if (!args_count(1, 1, "write-vin VIN")) return false;
    const std::string& vin = o->args[0];
    bool ok = vin.size() == uds::kVinSize;
    for (char ch : vin)
      ok = ok && ((ch >= '0' && ch <= '9') ||
                  (ch >= 'A' && ch <= 'Z' && ch != 'I' && ch != 'O' && ch != 'Q'));
    if (!ok) {
      *error =
          "a VIN is 17 characters of 0-9 and A-Z without I, O, Q (ISO 3779; got '" + vin + "')";
      return false;
    }
  } else if (c == "raw") {
    std::string joined;
    for (const std::string& a : o->args) joined += a + " ";
    std::vector<uint8_t> bytes;
    if (o->args.empty() || !ParseHex(joined, &bytes)) {
      *error = "raw takes the request in hex, whole bytes, e.g. \"22 F1 90\"";
      return false;
    }
  } else {
    *error = "unknown command '" + c + "' (see --help)";
    return false;
  }
  if ((o->static_mode || have_max_duration || o->no_wait) && !IsRoutineCommand(c)) {
    *error = "--static, --max-duration and --no-wait go with calibrate or verify";
    return false;
  }
  if (o->clear && c != "dtc") {
    *error = "--clear goes with dtc";
    return false;
  }
  if (o->functional && c != "raw" && c != "tester-present") {
    *error = "--functional goes with raw or tester-present";
    return false;
  }
  std::string config_error;
  if (!o->isotp.IsValid(&config_error)) {
    *error = config_error;
    return false;
  }
  return true;
}

int RunTester(const TesterOptions& options, std::ostream& out, std::ostream& err) {
  UdsClient client;
  std::string error;
  if (!client.Open(options.isotp, options.timing, &error)) {
    err << kPrefix << error << "\n";
    return kExitInterface;
  }
  return RunCommand(client, options, out, err);
}

}  // namespace calibd::tester
