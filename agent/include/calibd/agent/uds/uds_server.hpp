#pragma once
/// \file
/// The UDS server's protocol core (ISO 14229-1), independent of the transport: one request in,
/// one response (or none) out, from a fixed buffer; no allocation per request except where noted.
///
/// Services and the sessions they are available in (0x7F serviceNotSupportedInActiveSession
/// elsewhere):
///
/// | SID  | service                     | sub-functions / ids            | default | extended |
/// |------|-----------------------------|--------------------------------|---------|----------|
/// | 0x10 | DiagnosticSessionControl    | 01 default, 03 extended        | yes     | yes      |
/// | 0x11 | ECUReset                    | 01 hardReset                   | yes     | yes      |
/// | 0x14 | ClearDiagnosticInformation  | group 0xFFFFFF                 | yes     | yes      |
/// | 0x19 | ReadDTCInformation          | 01, 02, 04, 06, 0A             | yes     | yes      |
/// | 0x22 | ReadDataByIdentifier        | did_codec.hpp, up to 16 DIDs   | yes     | yes      |
/// | 0x27 | SecurityAccess              | 01 requestSeed, 02 sendKey     | no      | yes      |
/// | 0x2E | WriteDataByIdentifier       | 0xF190 VIN, unlocked           | no      | yes      |
/// | 0x31 | RoutineControl              | routines.hpp; start/stop unlocked | no   | yes      |
/// | 0x3E | TesterPresent               | 00                             | yes     | yes      |
/// | 0x85 | ControlDTCSetting           | 01 on, 02 off                  | no      | yes      |
///
/// NRC order (ISO 14229-1 §7.5, Figures 5 and 6): 0x11 unknown SID, 0x7F not in this session,
/// then for services with a sub-function 0x13 shorter than 2 bytes, 0x12 unknown sub-function,
/// (0x7E: never, as every session restriction here is per service), then each service's own
/// checks: identifier (0x31), security (0x33), sequence (0x24), exact length (0x13), data range
/// (0x31), conditions (0x22), then the owner's answer (routines.hpp, uds_backend.hpp). A
/// functionally addressed request gets no 0x11, 0x12, 0x31, 0x7E or 0x7F negative response
/// (§7.5); suppressPosRspMsgIndicationBit suppresses the positive response of a service with a
/// sub-function, never a negative one.
///
/// Session rules (§9.2.1): leaving the extended session (for the default one, or re-entering
/// it) locks security; returning to the default session (0x10 01 or S3 expiry) also aborts a
/// calibrate/verify routine started in that session and turns DTC setting back on.
///
/// Allocation: answering 0x10, 0x3E, 0x22, 0x19, 0x31 results, and every NRC allocates nothing.
/// 0x27 sendKey (OpenSSL's HMAC), and requests that write a state file (a failed key, 0x14, a
/// DTC status change) allocate; none of them is periodic.

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/agent/uds/dtc_store.hpp"
#include "calibd/agent/uds/security_access.hpp"
#include "calibd/agent/uds/uds_backend.hpp"
#include "calibd/agent/uds/uds_config.hpp"
#include "calibd/agent/uds/uds_types.hpp"

namespace calibd::uds {

/// Most DIDs accepted in one 0x22 request (more: 0x13).
inline constexpr size_t kMaxDidsPerRead = 16;

/// True for the requests whose answer may wait for a write to storage, each file written and
/// fsync'd (RoutineControl start or stop: the session marker, the commit and restore versions
/// and exports; SecurityAccess sendKey: the attempt counter; WriteDataByIdentifier: the VIN;
/// ClearDiagnosticInformation: the DTC file). On a slow or busy filesystem that takes longer
/// than P2: the transport sends 0x78 requestCorrectlyReceived-ResponsePending for them first
/// (ISO 14229-2 §7.2, then the final answer within P2*), and tells Handle it did.
bool MayWriteStorage(const uint8_t* request, size_t size);

class UdsServer {
 public:
  /// `config` must be valid (UdsConfig::IsValid); `backend` outlives the server.
  UdsServer(const UdsConfig& config, UdsBackend* backend);

  /// Loads the secret (false with `error` when missing or badly protected: the server must not
  /// run), the persisted lockout and the DTC store (problems with those two are warnings()).
  /// `now_us` monotonic, `now_unix_us` the wall clock at the same moment.
  bool Init(int64_t now_us, int64_t now_unix_us, std::string* error);

  /// One request (the SID first). `functional`: it came on the functional address. `now_us`
  /// monotonic. `pending_sent`: a 0x78 responsePending went out for it, so the final positive
  /// response is sent even when suppressPosRspMsgIndicationBit asked for none (ISO 14229-1
  /// §7.5.2: a tester that heard 0x78 waits for the final answer). The response stays valid
  /// until the next call.
  Response Handle(const uint8_t* request, size_t size, bool functional, int64_t now_us,
                  bool pending_sent = false);
  /// Advances the S3 timer: back to the default session once s3_us passed without a request.
  void Tick(int64_t now_us);

  Session session() const { return session_; }
  bool security_unlocked() const { return security_.unlocked(); }
  /// The DTC store, for the owner's test results (Report).
  DtcStore& dtcs() { return dtcs_; }
  const DtcStore& dtcs() const { return dtcs_; }
  /// Problems found at Init with the lockout or DTC files (for the log); empty when none.
  std::string warnings() const;

 private:
  /// Handles one request; returns the response size in buffer_ (0: none), or sets nrc_.
  size_t Dispatch(const uint8_t* req, size_t size, int64_t now_us);
  size_t SessionControl(const uint8_t* req, size_t size);
  size_t EcuReset(const uint8_t* req, size_t size);
  size_t ClearDtc(const uint8_t* req, size_t size);
  size_t ReadDtc(const uint8_t* req, size_t size);
  size_t ReadData(const uint8_t* req, size_t size);
  size_t SecurityAccessService(const uint8_t* req, size_t size, int64_t now_us);
  size_t WriteData(const uint8_t* req, size_t size);
  size_t RoutineControl(const uint8_t* req, size_t size);
  size_t TesterPresent(const uint8_t* req, size_t size);
  size_t ControlDtcSetting(const uint8_t* req, size_t size);
  /// Appends one DID's record at `out`; 0 when the DID is not supported; SIZE_MAX if it does not
  /// fit in `room`.
  size_t ReadOneDid(uint16_t did, uint8_t* out, size_t room);
  /// Writes the RoutineControl response header (sub-function, RID) and one status byte.
  size_t RoutineReply(const uint8_t* req, uint8_t status);
  void EnterDefaultSession();
  size_t Fail(Nrc nrc) {
    nrc_ = nrc;
    return 0;
  }

  UdsConfig config_;
  UdsBackend* backend_;
  SecurityAccess security_;
  DtcStore dtcs_;
  Session session_ = Session::kDefault;
  int64_t last_request_us_ = 0;
  Nrc nrc_ = kNrcNone;
  bool suppress_positive_ = false;
  /// Routines started since the agent started (results before any start: 0x24), and the
  /// status of the last commit / restore.
  bool calibrate_started_ = false;
  /// calibrate/verify started in the current extended session: aborted when it ends.
  bool routine_started_in_session_ = false;
  RoutineStatus commit_status_ = RoutineStatus::kIdle;
  RoutineStatus restore_status_ = RoutineStatus::kIdle;
  RoutineStatus store_reference_status_ = RoutineStatus::kIdle;
  /// The last-start status of a store routine (commit, restore, store-reference).
  RoutineStatus& StoreRoutineStatus(uint16_t rid);
  std::array<uint8_t, kMaxMessageSize> buffer_{};
};

}  // namespace calibd::uds
