#pragma once
/// \file
/// The agent's workshop and factory-line interfaces, composed for its poll loop: the
/// UDS server (agent/uds/uds_server.hpp) on the kernel's ISO-TP sockets, the 1 Hz cyclic status
/// frame (core/status_frame.hpp) on a raw CAN socket that also watches error frames for bus-off,
/// and the GPIO lines (interlock, start button, status lamp). Each part is optional (agent.can,
/// agent.gpio); with neither, every method is a cheap no-op.
///
/// Threading: none of its own; the agent's poll loop calls every method. Requests are answered
/// as they are read (OnReadable), well within P2 = 50 ms; the timer (Tick) supervises the links,
/// runs the S3 timer, sends the status frame and drives the lamp.

#include <poll.h>

#include <array>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>

#include "calibd/agent/agent_config.hpp"
#include "calibd/agent/uds/uds_backend.hpp"
#include "calibd/agent/uds/uds_server.hpp"
#include "calibd/core/common/status_frame.hpp"
#include "calibd/drivers/can_raw_socket.hpp"
#include "calibd/drivers/gpio_lines.hpp"
#include "calibd/drivers/isotp_channel.hpp"

namespace calibd {

/// What the agent shows on the status frame and the lamp, given at every Tick.
struct DiagnosticsView {
  StatusFrame status;
  LampState lamp = LampState::kIdle;
};

class Diagnostics {
 public:
  using LogFn = std::function<void(const std::string&)>;
  /// Descriptors PollFds() may add: ISO-TP physical and functional, raw CAN, start button.
  static constexpr int kMaxPollFds = 4;

  Diagnostics() = default;
  Diagnostics(const Diagnostics&) = delete;
  Diagnostics& operator=(const Diagnostics&) = delete;

  /// Sets up what `config` enables. False with `error` when: the UDS secret file is missing or
  /// not protected (the server must not run), the state directory is unusable, or a GPIO line
  /// cannot be requested. A CAN interface that is missing or down is not an error: it is
  /// retried with backoff and reported in the log and the link counters. `backend` outlives this.
  bool Start(const AgentConfig& config, uds::UdsBackend* backend, LogFn log, int64_t now_us,
             int64_t now_unix_us, std::string* error);

  bool can_enabled() const { return can_enabled_; }
  /// Writes the descriptors to poll for POLLIN (only those open now; read afresh every loop
  /// iteration, as a link going down closes its sockets); returns how many.
  int PollFds(pollfd* fds) const;
  /// Handles whatever is waiting, without blocking: UDS requests (each answered at once), frames
  /// and error frames on the raw socket (bus-off), start-button edges.
  void OnReadable(int64_t now_us);
  /// Timer work: link reopen and error collection, S3, the status frame once a second, the lamp
  /// pattern, a debounced button press that completed, a response still waiting to be sent.
  void Tick(int64_t now_us, const DiagnosticsView& view);

  /// True once per debounced start-button press.
  bool TakeStartPress();
  /// The interlock's level: true when asserted or when no interlock line is configured.
  bool Interlock() const;
  bool has_interlock() const { return gpio_enabled_ && gpio_.has_interlock(); }

  /// A DTC test result (dtc_store.hpp); no-op without UDS. Persistence failures are logged.
  void Report(uds::Dtc dtc, bool failed);
  /// The UDS server; null without agent.can.
  uds::UdsServer* server() { return server_.get(); }
  bool bus_off() const { return bus_off_; }
  const CanLinkStatus* isotp_status() const { return can_enabled_ ? &isotp_.status() : nullptr; }
  const CanLinkStatus* raw_status() const { return can_enabled_ ? &raw_.status() : nullptr; }
  int64_t status_frames_sent() const { return status_frames_sent_; }

 private:
  void HandleRequests(int64_t now_us);
  void SendResponse(const uint8_t* data, size_t size);
  void WatchLinks();

  LogFn log_;
  bool can_enabled_ = false, gpio_enabled_ = false;
  uint32_t status_frame_id_ = 0;
  UdsServerTransport isotp_;
  CanRawSocket raw_;
  std::unique_ptr<uds::UdsServer> server_;
  mutable GpioLines gpio_;  ///< mutable: reading the interlock counts read errors
  StatusFrameCounter counter_;
  int64_t last_status_frame_us_ = 0;
  int64_t status_frames_sent_ = 0;
  bool bus_off_ = false;
  bool start_press_ = false;
  CanLinkState isotp_state_ = CanLinkState::kClosed, raw_state_ = CanLinkState::kClosed;
  int64_t logged_rx_errors_ = 0;  ///< UDS requests lost (over-long, ISO-TP errors): last logged
  /// A response the kernel could not take yet (the previous one still sending): sent on the
  /// next OnReadable or Tick.
  std::array<uint8_t, uds::kMaxMessageSize> pending_{};
  size_t pending_size_ = 0;
};

}  // namespace calibd
