#pragma once
/// \file
/// ISO-TP (ISO 15765-2) over the kernel's CAN_ISOTP sockets (Linux >= 5.10, net/can/isotp.c),
/// for UDS (ISO 14229-1) on CAN: the ECU side (UdsServerTransport, the agent) and the tester side
/// (UdsClientTransport, calibd-tester and tests). The kernel does the segmentation, flow control,
/// padding and timing (N_Bs 1 s, N_Cr 1 s); we set it up from IsoTpConfig and move whole
/// messages. No <linux/can*> type appears here.
///
/// Addressing (ISO 15765-4 normal addressing, 11-bit defaults of OBD/UDS on CAN):
/// - physical request 0x7E0 (tester -> ECU), physical response 0x7E8 (ECU -> tester);
/// - functional request 0x7DF (tester -> all ECUs). Functional requests are single frames only
///   (ISO 15765-2 §9.6.2): the ECU's functional socket is in listen mode (CAN_ISOTP_LISTEN_MODE,
///   it never sends a flow control), so a multi-frame functional request does not complete and
///   the tester side sends functionally with CAN_ISOTP_SF_BROADCAST (a longer message is
///   refused with EINVAL by the kernel). The ECU answers every request on its physical socket.
/// - 29-bit ids: set extended_ids and the three ids (e.g. normal fixed addressing, ISO 15765-2
///   §10.3.3: 0x18DA<ecu><tester> physical, 0x18DB33<tester> functional).
///
/// Sockets are non-blocking. Send() hands a message to the kernel and returns; the kernel sends
/// its consecutive frames from a timer, so a second Send() before the first finished reports
/// kBusy. A transfer that fails afterwards (no flow control within N_Bs = 1 s) is reported by
/// the next Receive() (or collected by Tick()) as kError with the kernel's ECOMM text and counted
/// in tx_errors; a message whose reception stops (no consecutive frame within N_Cr = 1 s) as
/// kError with ETIMEDOUT, counted in rx_errors. Neither takes the link down.
///
/// Link failures (interface down or gone) are handled as can_link.hpp describes: the sockets are
/// closed, the fds become -1, and Tick(now_us) reopens them with backoff. The poll loop must
/// therefore read physical_fd()/functional_fd() afresh on every iteration.
///
/// Bus-off: ISO-TP sockets receive no error frames; the agent sees a bus-off on its CanRawSocket
/// (status frame, error_frames on). Meanwhile ISO-TP sends fail (ENOBUFS: kError) or time out
/// (ECOMM); the link stays up.
///
/// Memory: one fixed kIsoTpMaxMessage-byte receive buffer per transport, allocated at
/// construction; Send/Receive/Tick allocate nothing while the link is up (a link loss formats an
/// error string).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/can_link.hpp"

namespace calibd {

/// Longest ISO-TP message: 12-bit first-frame length (ISO 15765-2 §9.6.3; the 32-bit escape
/// of the 2016 edition is not used).
constexpr size_t kIsoTpMaxMessage = 4095;

/// ISO-TP settings of one CAN interface; every field can come from the agent's config.
struct IsoTpConfig {
  std::string interface = "can0";
  uint32_t physical_request_id = 0x7E0;    ///< tester -> ECU
  uint32_t physical_response_id = 0x7E8;   ///< ECU -> tester
  uint32_t functional_request_id = 0x7DF;  ///< tester -> all ECUs (single frames)
  /// 29-bit identifiers (CAN_EFF_FLAG) for all three ids; 11-bit otherwise.
  bool extended_ids = false;
  /// Pad every frame to 8 bytes (classic CAN: DLC 8) or to the next CAN FD length. On by default:
  /// many ECUs and testers require DLC 8 (ISO 15765-2 §10.4.2.1 leaves it to the OEM).
  bool padding = true;
  /// Pad byte on transmit; 0xCC is the kernel's default and ISO 15765-2's recommendation (few
  /// stuff bits); 0x55 or 0xAA are common OEM choices. Received padding is not checked.
  uint8_t pad_byte = 0xCC;
  /// Block size we ask senders for in our flow control frames: consecutive frames between flow
  /// controls; 0 = all at once (fastest; the kernel's buffer holds the whole message).
  uint8_t block_size = 0;
  /// STmin we ask senders for (ISO 15765-2 §9.6.5.4 encoding): 0x00-0x7F = 0-127 ms, 0xF1-0xF9 =
  /// 100-900 us. 0 = no gap needed.
  uint8_t st_min = 0;
  /// Flow-control WAIT frames we accept before aborting a receive (0: none).
  uint8_t wait_frames_max = 0;
  /// Forces the gap between our consecutive frames to at least this, ns, whatever the receiver's
  /// flow control asks (CAN_ISOTP_TX_STMIN + CAN_ISOTP_FORCE_TXSTMIN); 0 = honour the receiver.
  /// For slow gateways that under-report their STmin.
  uint32_t forced_tx_st_min_ns = 0;
  /// CAN FD frames (the interface needs MTU 72): up to fd_tx_dl bytes per frame; receives
  /// accept classic and FD frames of any length.
  bool can_fd = false;
  /// Transmit data length with CAN FD: 8, 12, 16, 20, 24, 32, 48 or 64.
  uint8_t fd_tx_dl = 64;
  CanReopenPolicy reopen;

  /// False with `error` naming the field: empty or too long interface name, an id beyond 11 (or
  /// 29) bits, equal request and response ids, a reserved STmin, a bad fd_tx_dl, bad backoff.
  bool IsValid(std::string* error) const;
};

/// Outcome of one Send() or Receive().
enum class IsoTpIo {
  kOk,        ///< sent (handed to the kernel) / a message was received
  kNone,      ///< Receive: nothing waiting
  kBusy,      ///< Send: the previous message is still being sent; try again later
  kLinkDown,  ///< the link is not up (or just went down): status() says why
  kError,     ///< this message failed (too long, ISO-TP timeout or sequence error): status()
};

const char* ToString(IsoTpIo io);

/// A received message: `data` points into the transport's buffer, valid until its next Receive.
struct IsoTpMessage {
  const uint8_t* data = nullptr;
  size_t size = 0;
  bool functional = false;  ///< came on the functional id (server side only)
};

/// One CAN_ISOTP socket: RAII over the fd, set up from IsoTpConfig. Building block of the two
/// transports below; usable alone (e.g. a listen-mode sniffer).
class IsoTpSocket {
 public:
  /// Socket flavours: kNormal sends and receives; kListenOnly never sends a flow control
  /// (CAN_ISOTP_LISTEN_MODE); kBroadcastTx sends single frames only and receives nothing
  /// (CAN_ISOTP_SF_BROADCAST).
  enum class Mode { kNormal, kListenOnly, kBroadcastTx };

  IsoTpSocket() = default;
  ~IsoTpSocket();
  IsoTpSocket(const IsoTpSocket&) = delete;
  IsoTpSocket& operator=(const IsoTpSocket&) = delete;

  /// Creates, configures and binds a non-blocking socket on `ifindex` sending on `tx_id` and
  /// receiving on `rx_id` (without CAN_EFF_FLAG: config.extended_ids adds it). False with `error`
  /// naming the call and errno in `*err` (e.g. EPROTONOSUPPORT: the can-isotp module is missing).
  bool Open(const IsoTpConfig& config, int ifindex, uint32_t tx_id, uint32_t rx_id, Mode mode,
            std::string* error, int* err);
  void Close();
  int fd() const { return fd_; }

 private:
  int fd_ = -1;
};

namespace isotp_detail {
/// Shared by the two transports: the link supervision and the receive buffer.
class TransportBase {
 public:
  virtual ~TransportBase() = default;
  const CanLinkStatus& status() const { return link_.status(); }
  const IsoTpConfig& config() const { return config_; }

 protected:
  IsoTpIo SendOn(IsoTpSocket& socket, const uint8_t* data, size_t size);
  /// Reads one message from `socket` into buffer_ (non-blocking).
  IsoTpIo ReceiveOn(IsoTpSocket& socket, IsoTpMessage* out);
  /// Handles errno `err` of a call on an up link: link error -> close all, kLinkDown; else
  /// kError, counted as a tx error when `sending` or ECOMM (our transfer failed), else rx.
  IsoTpIo Fail(int err, const char* what, bool sending);
  void CloseSockets();
  virtual bool OpenSockets(int ifindex, std::string* error, int* err) = 0;
  bool StartBase(const IsoTpConfig& config, int64_t now_us, std::string* error);
  void TickBase(int64_t now_us);
  void TryOpen();

  IsoTpConfig config_;
  CanLinkSupervisor link_;
  IsoTpSocket physical_;
  IsoTpSocket functional_;
  std::array<uint8_t, kIsoTpMaxMessage + 1> buffer_{};  ///< +1: an over-long message shows
};
}  // namespace isotp_detail

/// ECU side (the agent): a physical socket (rx physical_request_id, tx physical_response_id)
/// and a functional one (rx functional_request_id, listen mode, never sends). Both fds go into
/// the agent's poll loop; every response goes out on the physical socket.
class UdsServerTransport : public isotp_detail::TransportBase {
 public:
  UdsServerTransport() = default;
  ~UdsServerTransport() override;

  /// Validates `config` and makes the first open try at `now_us`. False with `error` only for an
  /// invalid config; an interface that is missing or down is retried by Tick() (see status()).
  bool Start(const IsoTpConfig& config, int64_t now_us, std::string* error);
  /// Closes the sockets; status kClosed.
  void Stop();
  /// Retries opening when the link is not up and the backoff delay has passed; while it is up,
  /// collects the sockets' pending errors (SO_ERROR: ENETDOWN, ENODEV, a transfer's ECOMM), so a
  /// link loss is seen even on a socket nobody reads. Call from the poll loop's timer (every
  /// 10-100 ms is plenty).
  void Tick(int64_t now_us) { TickBase(now_us); }

  /// -1 while the link is not up.
  int physical_fd() const { return physical_.fd(); }
  int functional_fd() const { return functional_.fd(); }

  /// The next waiting request, physical before functional; kNone when none waits.
  IsoTpIo Receive(IsoTpMessage* out);
  /// Sends a response (1..kIsoTpMaxMessage bytes) on the physical response id.
  IsoTpIo Send(const uint8_t* data, size_t size);

 private:
  bool OpenSockets(int ifindex, std::string* error, int* err) override;
};

/// Tester side: physical socket (tx physical_request_id, rx physical_response_id) and a
/// functional one (tx functional_request_id, single frames only, receives nothing: responses to
/// functional requests come on the physical response id).
class UdsClientTransport : public isotp_detail::TransportBase {
 public:
  UdsClientTransport() = default;
  ~UdsClientTransport() override;

  /// As UdsServerTransport::Start.
  bool Start(const IsoTpConfig& config, int64_t now_us, std::string* error);
  void Stop();
  void Tick(int64_t now_us) { TickBase(now_us); }

  /// The fd responses arrive on; -1 while the link is not up.
  int fd() const { return physical_.fd(); }

  /// Sends a request physically (1..kIsoTpMaxMessage bytes).
  IsoTpIo SendPhysical(const uint8_t* data, size_t size);
  /// Sends a request functionally: one single frame (up to 7 bytes classic, 62 with CAN FD).
  IsoTpIo SendFunctional(const uint8_t* data, size_t size);
  /// The next response; kNone when none waits.
  IsoTpIo Receive(IsoTpMessage* out);

 private:
  bool OpenSockets(int ifindex, std::string* error, int* err) override;
};

}  // namespace calibd
