#include "calibd/agent/diagnostics.hpp"

#include <sys/stat.h>

#include <cerrno>
#include <cstring>

namespace calibd {

bool Diagnostics::Start(const AgentConfig& config, uds::UdsBackend* backend, LogFn log,
                        int64_t now_us, int64_t now_unix_us, std::string* error) {
  log_ = std::move(log);
  can_enabled_ = config.can_enabled;
  gpio_enabled_ = config.gpio.interlock.enabled || config.gpio.start_button.enabled ||
                  config.gpio.status_lamp.enabled;
  if (gpio_enabled_ && !gpio_.Open(config.gpio, error)) return false;
  if (!can_enabled_) return true;

  // The server's state (DTCs, lockout, VIN) lives there: created owner-only on first start, as
  // the calibration store's directory is; its parent must exist.
  struct stat st {};
  if (::stat(config.uds.state_dir.c_str(), &st) != 0 &&
      (errno != ENOENT || ::mkdir(config.uds.state_dir.c_str(), 0700) != 0)) {
    *error =
        "agent.uds.state_dir: cannot create " + config.uds.state_dir + ": " + std::strerror(errno);
    return false;
  }
  if (::stat(config.uds.state_dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode)) {
    *error = "agent.uds.state_dir: " + config.uds.state_dir + " is not a directory";
    return false;
  }
  server_ = std::make_unique<uds::UdsServer>(config.uds, backend);
  if (!server_->Init(now_us, now_unix_us, error)) {
    *error = "agent.uds: " + *error;
    return false;
  }
  if (!server_->warnings().empty()) log_("uds: " + server_->warnings());
  if (!isotp_.Start(config.isotp, now_us, error)) return false;
  CanRawConfig raw;
  raw.interface = config.isotp.interface;
  raw.reopen = config.isotp.reopen;
  raw.error_frames = true;  // no data filters: it only sends and watches for bus-off
  if (!raw_.Start(raw, now_us, error)) return false;
  status_frame_id_ = config.status_frame_id;
  WatchLinks();
  return true;
}

int Diagnostics::PollFds(pollfd* fds) const {
  int n = 0;
  auto add = [&](int fd) {
    if (fd >= 0) fds[n++] = pollfd{fd, POLLIN, 0};
  };
  if (can_enabled_) {
    // While a response waits for the kernel to finish the previous one, the requests wait in
    // their sockets (the timer retries the send) instead of waking the loop without end.
    if (pending_size_ == 0) {
      add(isotp_.physical_fd());
      add(isotp_.functional_fd());
    }
    add(raw_.fd());
  }
  if (gpio_enabled_) add(gpio_.event_fd());
  return n;
}

void Diagnostics::SendResponse(const uint8_t* data, size_t size) {
  const IsoTpIo io = isotp_.Send(data, size);
  if (io == IsoTpIo::kBusy) {  // the previous response is still going out: send it after
    std::memcpy(pending_.data(), data, size);
    pending_size_ = size;
  } else {
    pending_size_ = 0;
  }
}

void Diagnostics::HandleRequests(int64_t now_us) {
  if (pending_size_ > 0) SendResponse(pending_.data(), pending_size_);
  if (pending_size_ > 0) return;  // one response at a time: the requests wait in the socket
  IsoTpMessage m;
  while (isotp_.Receive(&m) == IsoTpIo::kOk) {
    // A request that may wait for storage hears 0x78 first, before any file is touched: within
    // P2 however slow the filesystem (uds_server.hpp, MayWriteStorage). Only when it goes out
    // now: with the previous response still being sent, the final answer waits its turn alone.
    bool pending_sent = false;
    if (!m.functional && uds::MayWriteStorage(m.data, m.size)) {
      const uint8_t pending[3] = {uds::kSidNegativeResponse, m.data[0], uds::kNrcResponsePending};
      pending_sent = isotp_.Send(pending, sizeof(pending)) == IsoTpIo::kOk;
    }
    const uds::Response r = server_->Handle(m.data, m.size, m.functional, now_us, pending_sent);
    if (!r.empty()) SendResponse(r.data, r.size);
    if (pending_size_ > 0) return;
  }
}

void Diagnostics::OnReadable(int64_t now_us) {
  if (can_enabled_) {
    HandleRequests(now_us);
    CanFrame frame;
    for (int i = 0; i < 64 && raw_.Receive(&frame) == CanIo::kOk; ++i) {
    }
    WatchLinks();
  }
  if (gpio_enabled_ && gpio_.HandleEvents(now_us)) start_press_ = true;
}

void Diagnostics::WatchLinks() {
  const CanLinkState isotp = isotp_.status().state, raw = raw_.status().state;
  if (isotp != isotp_state_) {
    log_(std::string("CAN ") + isotp_.config().interface + " (UDS): " + ToString(isotp) +
         (isotp == CanLinkState::kUp ? "" : ": " + isotp_.status().last_error));
    isotp_state_ = isotp;
  }
  // Requests lost in reception (longer than the kIsoTpMaxMessage-byte buffer, ISO-TP timeouts or
  // sequence errors): the tester sees no answer, the log says why.
  const int64_t rx_errors = isotp_.status().counters.rx_errors;
  if (rx_errors != logged_rx_errors_) {
    log_("CAN " + isotp_.config().interface + " (UDS): " + std::to_string(rx_errors) +
         " requests lost in reception so far (last error: " + isotp_.status().last_error + ")");
    logged_rx_errors_ = rx_errors;
  }
  if (raw != raw_state_) {
    if (raw == CanLinkState::kBusOff) {
      log_("CAN " + isotp_.config().interface + ": bus-off");
      Report(uds::Dtc::kCanBusOff, true);
      bus_off_ = true;
    } else if (raw == CanLinkState::kUp) {
      if (bus_off_) log_("CAN " + isotp_.config().interface + ": back on the bus");
      Report(uds::Dtc::kCanBusOff, false);
      bus_off_ = false;
    }
    raw_state_ = raw;
  }
}

void Diagnostics::Tick(int64_t now_us, const DiagnosticsView& view) {
  if (can_enabled_) {
    isotp_.Tick(now_us);
    raw_.Tick(now_us);
    server_->Tick(now_us);
    HandleRequests(now_us);
    if (now_us - last_status_frame_us_ >= 1000000) {
      const StatusFrameBytes bytes = EncodeStatusFrame(view.status, counter_.Next());
      if (raw_.Send(status_frame_id_, status_frame_id_ > 0x7FF, bytes.data(), bytes.size()) ==
          CanIo::kOk)
        ++status_frames_sent_;
      // Once a second whether it went out or not: a bus that is off gets no burst later.
      last_status_frame_us_ = now_us;
    }
    WatchLinks();
  }
  if (gpio_enabled_) {
    if (gpio_.HandleEvents(now_us)) start_press_ = true;
    gpio_.SetLampState(view.lamp, now_us);
    gpio_.UpdateLamp(now_us);
  }
}

bool Diagnostics::TakeStartPress() {
  const bool pressed = start_press_;
  start_press_ = false;
  return pressed;
}

bool Diagnostics::Interlock() const { return !gpio_enabled_ || gpio_.interlock(); }

void Diagnostics::Report(uds::Dtc dtc, bool failed) {
  if (server_ == nullptr) return;
  std::string error;
  if (!server_->dtcs().Report(dtc, failed, &error)) log_("DTC store: " + error);
}

}  // namespace calibd
