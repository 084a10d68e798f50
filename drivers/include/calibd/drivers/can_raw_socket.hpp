#pragma once
/// \file
/// Raw SocketCAN (CAN_RAW) socket for classic frames: the cyclic status frame (send), receive
/// filters (tests, monitoring) and the controller's error frames (CAN_RAW_ERR_FILTER), which is
/// how a bus-off becomes visible to the agent. Link loss and reopening as can_link.hpp describes.
/// No <linux/can*> type appears here; nothing allocates per data frame (an error frame or a link
/// loss formats status().last_error).

#include <array>
#include <cstddef>
#include <cstdint>
#include <string>

#include "calibd/drivers/can_link.hpp"

namespace calibd {

/// Accept frames whose id matches `id` in the bits of `mask` (CAN_RAW_FILTER semantics), of the
/// kind given by `extended` (the IDE bit is always compared).
struct CanRawFilter {
  uint32_t id = 0;
  uint32_t mask = 0;
  bool extended = false;
};

struct CanRawConfig {
  static constexpr size_t kMaxFilters = 8;

  std::string interface = "can0";
  /// Receive filters, the first `num_filters` used. 0 filters: receive no data frames (a socket
  /// that only sends and watches error frames, the agent's use).
  std::array<CanRawFilter, kMaxFilters> filters{};
  size_t num_filters = 0;
  /// Receive the controller's error frames: bus-off, restarted, controller problems (error
  /// passive/warning, overflows), transceiver, no-ACK and TX timeouts. Bus errors
  /// (CAN_ERR_BUSERROR/CAN_ERR_PROT) are left out: they can flood.
  bool error_frames = true;
  CanReopenPolicy reopen;

  /// False with `error` naming the field (interface name, num_filters, filter ids, backoff).
  bool IsValid(std::string* error) const;
};

/// A classic CAN frame.
struct CanFrame {
  uint32_t id = 0;  ///< without flags
  bool extended = false;
  uint8_t len = 0;  ///< 0-8
  std::array<uint8_t, 8> data{};
  int64_t timestamp_ns = 0;  ///< kernel receive time (CLOCK_REALTIME, SO_TIMESTAMPNS); 0 on send
};

/// A decoded SocketCAN error frame (linux/can/error.h).
struct CanErrorFrame {
  uint32_t classes = 0;  ///< CAN_ERR_* class bits of the id (without CAN_ERR_FLAG)
  bool bus_off = false;
  bool restarted = false;
  bool tx_timeout = false;
  bool no_ack = false;
  bool lost_arbitration = false;
  bool bus_error = false;
  bool protocol_violation = false;
  bool transceiver = false;
  bool controller = false;  ///< CAN_ERR_CRTL; details below from data[1]
  bool error_warning = false;
  bool error_passive = false;
  bool error_active_again = false;
  bool rx_overflow = false;
  bool tx_overflow = false;
  bool has_counters = false;  ///< CAN_ERR_CNT: the counters below are valid
  uint8_t tx_error_count = 0;
  uint8_t rx_error_count = 0;
};

/// Decodes an error frame's id (with or without CAN_ERR_FLAG) and 8 data bytes. Pure.
CanErrorFrame DecodeCanErrorFrame(uint32_t can_id, const std::array<uint8_t, 8>& data);
/// "bus-off", "controller: error passive (tx 128, rx 0)", ...: for logs. Allocates.
std::string Describe(const CanErrorFrame& error);

/// Outcome of a Send() or Receive().
enum class CanIo {
  kOk,          ///< sent / a data frame received
  kErrorFrame,  ///< Receive: an error frame came (decoded in last_error_frame(), counted)
  kNone,        ///< Receive: nothing waiting
  kBusy,        ///< Send: the interface's queue is full (ENOBUFS; e.g. during bus-off)
  kLinkDown,    ///< the link is not up; status() says why
  kError,       ///< bad frame (id, length) or another errno: status().last_error
};

const char* ToString(CanIo io);

class CanRawSocket {
 public:
  CanRawSocket() = default;
  ~CanRawSocket();
  CanRawSocket(const CanRawSocket&) = delete;
  CanRawSocket& operator=(const CanRawSocket&) = delete;

  /// Validates `config` and makes the first open try at `now_us`; false with `error` only for an
  /// invalid config (a missing or downed interface is retried by Tick()).
  bool Start(const CanRawConfig& config, int64_t now_us, std::string* error);
  void Stop();
  /// Reopens when due (see can_link.hpp); while open, collects the socket's pending error
  /// (SO_ERROR) so a link loss is seen without a Send/Receive. Call from the poll loop's timer.
  void Tick(int64_t now_us);

  /// -1 while the link is not up; read it afresh every loop iteration.
  int fd() const { return fd_; }

  /// Sends one classic frame: `id` 11-bit (or 29-bit with `extended`), `len` 0-8 bytes. A
  /// successful send while kBusOff means the controller is back: state kUp.
  CanIo Send(uint32_t id, bool extended, const uint8_t* data, size_t len);
  /// The next data frame or error frame. An error frame with bus-off sets kBusOff and counts a
  /// bus-off event; one with "restarted" (or a controller back to error-active) sets kUp.
  CanIo Receive(CanFrame* out);

  const CanLinkStatus& status() const { return link_.status(); }
  /// The last error frame received (all false before any).
  const CanErrorFrame& last_error_frame() const { return last_error_frame_; }

 private:
  void TryOpen();
  CanIo Fail(int err, const char* what);

  CanRawConfig config_;
  CanLinkSupervisor link_;
  CanErrorFrame last_error_frame_;
  int fd_ = -1;
};

}  // namespace calibd
