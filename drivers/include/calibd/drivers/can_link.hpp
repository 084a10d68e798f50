#pragma once
/// \file
/// What the CAN transports (isotp_channel.hpp, can_raw_socket.hpp) share: the link state they
/// report, their counters, the reopen backoff and the check of the network interface.
///
/// How a SocketCAN link fails, and what the transports do (Linux 6.1, net/can/raw.c and
/// net/can/isotp.c, the `*_notify` netdevice handlers; measured in tests/vm/can_transport_vmtest):
/// - Interface goes down (`ip link set can0 down`, or a driver that stops after bus-off without
///   restart-ms): every bound socket gets sk_err = ENETDOWN (poll() reports POLLERR; the next
///   recv() returns it), and sends fail with ENETDOWN. The transport closes its sockets, reports
///   CanLinkState::kDown and retries with backoff; a retry finds the interface (if_nametoindex)
///   but not IFF_UP and stays kDown until it is up again, then binds fresh sockets: kUp.
/// - Interface disappears (USB adapter unplugged, `ip link del`): the kernel unbinds the sockets
///   (sk_err = ENODEV; an ISO-TP recv() then returns EADDRNOTAVAIL, measured on 6.1). Both mean
///   kNoInterface; if_nametoindex() fails on every retry and it stays so until an interface of
///   that name is back (perhaps with another index: every try looks the name up afresh).
/// - Bus-off (hardware only: vcan has no controller): the controller stops sending; the driver
///   reports it as an error frame with CAN_ERR_BUSOFF to raw sockets that asked for it
///   (CanRawSocket, error_frames), and CAN_ERR_RESTARTED once it is back (restart-ms or
///   `ip link set can0 type can restart`). Sends meanwhile fail with ENOBUFS (queue full) or sit
///   in the queue. The raw socket counts bus-off events and reports kBusOff until it sees the
///   restart or a send succeeds.
/// No method blocks or sleeps and nothing runs in a thread: the agent's loop calls Tick(now_us)
/// from its timer, which makes the retries when they are due.

#include <cstdint>
#include <string>

namespace calibd {

/// State of one CAN transport's link.
enum class CanLinkState {
  kClosed,       ///< Start() not called, or Stop()
  kUp,           ///< sockets bound, interface up
  kDown,         ///< interface exists but is not up (or went down): retrying
  kNoInterface,  ///< no interface of that name: retrying
  kBusOff,       ///< raw socket saw CAN_ERR_BUSOFF: the controller is off the bus
  kFailed,       ///< could not create or bind a socket for another reason: retrying
};

const char* ToString(CanLinkState state);

/// What a transport counted since Start(). All monotonic.
struct CanLinkCounters {
  int64_t reopen_attempts = 0;  ///< tries to open after the first one (each Tick that retried)
  int64_t reopens = 0;          ///< of those, successful
  int64_t link_losses = 0;     ///< times an up link was found down or gone (send, receive, POLLERR)
  int64_t bus_off_events = 0;  ///< error frames with CAN_ERR_BUSOFF
  int64_t error_frames = 0;    ///< error frames of any kind (raw socket with error_frames on)
  int64_t tx_messages = 0;     ///< messages (ISO-TP) or frames (raw) handed to the kernel
  int64_t rx_messages = 0;     ///< messages or frames received
  int64_t tx_errors = 0;       ///< sends refused for a reason other than the link (busy, ECOMM)
  int64_t rx_errors = 0;       ///< receive errors other than the link (ISO-TP timeouts, sequence)
};

/// The link's state, the last error's text and the counters.
struct CanLinkStatus {
  CanLinkState state = CanLinkState::kClosed;
  std::string last_error;  ///< names the interface and the call that failed; empty when none yet
  CanLinkCounters counters;
};

/// Reopen schedule: `initial_ms` after the link is lost, then doubling after each failed try, up
/// to `max_ms`; back to `initial_ms` once a try succeeds. Defaults: 100 ms, 200, 400, ... 5 s.
struct CanReopenPolicy {
  uint32_t initial_ms = 100;
  uint32_t max_ms = 5000;
  /// False with `error` when initial_ms is 0 or max_ms < initial_ms.
  bool IsValid(std::string* error) const;
};

/// The reopen schedule as plain arithmetic (host-testable): delay before try number
/// `failed_tries` + 1, counting the tries that failed since the link was lost.
int64_t ReopenDelayUs(const CanReopenPolicy& policy, int failed_tries);

/// State machine shared by the transports: when the next open try is due, and the status.
/// The owner calls Lost()/OpenFailed()/Opened() and asks Due() from its Tick().
class CanLinkSupervisor {
 public:
  /// Starts over with `policy` (state kClosed, counters zero). The owner then calls Due(now) to
  /// set the clock and makes the first try itself; its outcome is not counted as a reopen.
  void Reset(const CanReopenPolicy& policy);
  /// Remembers `now_us` (the time Lost() schedules from) and says whether a try is due.
  bool Due(int64_t now_us);
  /// A try at the last Tick's time succeeded: kUp, backoff reset.
  void Opened();
  /// A try failed with `state` (kDown, kNoInterface, kFailed) and `error`: next try later.
  void OpenFailed(CanLinkState state, std::string error);
  /// The up link failed (ENETDOWN, ENODEV, ...): `state`, `error`; the first retry is due
  /// initial_ms after the next Due() call (Send/Receive do not know the time).
  void Lost(CanLinkState state, std::string error);
  /// Records an error that does not take the link down.
  void SetError(std::string error) { status_.last_error = std::move(error); }
  void SetState(CanLinkState state) { status_.state = state; }

  bool up() const { return status_.state == CanLinkState::kUp; }
  const CanLinkStatus& status() const { return status_; }
  CanLinkCounters& counters() { return status_.counters; }
  /// When the next try is due (us, the Tick clock); meaningful while not up.
  int64_t next_try_us() const { return next_try_us_; }

 private:
  void Schedule(CanLinkState state, std::string error);

  CanReopenPolicy policy_;
  CanLinkStatus status_;
  int64_t last_now_us_ = 0;
  int64_t next_try_us_ = 0;
  int failed_tries_ = 0;
  bool first_try_ = true;
  bool schedule_pending_ = false;
};

/// Looks `name` up: its index in `ifindex` and kUp when it exists and is IFF_UP; kNoInterface
/// (if_nametoindex failed) or kDown (no IFF_UP) with `error` otherwise. With `mtu` non-null,
/// also its MTU (16 classic CAN, 72 CAN FD).
CanLinkState CheckCanInterface(const std::string& name, int* ifindex, int* mtu, std::string* error);

/// True for errno values that mean the link (not the message) failed: ENETDOWN, ENODEV, ENXIO,
/// ENETUNREACH, EADDRNOTAVAIL.
bool IsLinkErrno(int err);

/// A network interface name the kernel accepts (1 to IFNAMSIZ - 1 characters); false with
/// `error` ("interface: ..." naming it) otherwise.
bool CanInterfaceNameValid(const std::string& name, std::string* error);

/// A CAN id as the error texts write it: "0x7E0".
std::string CanIdText(uint32_t id);

}  // namespace calibd
