#include "calibd/drivers/can_raw_socket.hpp"

#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <sys/socket.h>
#include <sys/uio.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>

#include "calibd/core/common/validation.hpp"

namespace calibd {

const char* ToString(CanIo io) {
  switch (io) {
    case CanIo::kOk:
      return "ok";
    case CanIo::kErrorFrame:
      return "error_frame";
    case CanIo::kNone:
      return "none";
    case CanIo::kBusy:
      return "busy";
    case CanIo::kLinkDown:
      return "link_down";
    case CanIo::kError:
      return "error";
  }
  return "unknown";
}

bool CanRawConfig::IsValid(std::string* error) const {
  if (!CanInterfaceNameValid(interface, error)) return false;
  if (num_filters > kMaxFilters)
    return Invalid(
        error, "num_filters: " + std::to_string(num_filters) + " > " + std::to_string(kMaxFilters));
  for (size_t i = 0; i < num_filters; ++i) {
    const uint32_t max = filters[i].extended ? CAN_EFF_MASK : CAN_SFF_MASK;
    if (filters[i].id > max || filters[i].mask > max)
      return Invalid(error, "filters[" + std::to_string(i) + "]: id " + CanIdText(filters[i].id) +
                                " / mask " + CanIdText(filters[i].mask) + " beyond " +
                                (filters[i].extended ? "29" : "11") + " bits");
  }
  std::string reopen_error;
  if (!reopen.IsValid(&reopen_error)) return Invalid(error, reopen_error);
  return true;
}

CanErrorFrame DecodeCanErrorFrame(uint32_t can_id, const std::array<uint8_t, 8>& data) {
  CanErrorFrame e;
  e.classes = can_id & CAN_ERR_MASK;
  e.tx_timeout = (e.classes & CAN_ERR_TX_TIMEOUT) != 0;
  e.lost_arbitration = (e.classes & CAN_ERR_LOSTARB) != 0;
  e.controller = (e.classes & CAN_ERR_CRTL) != 0;
  e.protocol_violation = (e.classes & CAN_ERR_PROT) != 0;
  e.transceiver = (e.classes & CAN_ERR_TRX) != 0;
  e.no_ack = (e.classes & CAN_ERR_ACK) != 0;
  e.bus_off = (e.classes & CAN_ERR_BUSOFF) != 0;
  e.bus_error = (e.classes & CAN_ERR_BUSERROR) != 0;
  e.restarted = (e.classes & CAN_ERR_RESTARTED) != 0;
  if (e.controller) {
    const uint8_t crtl = data[1];
    e.rx_overflow = (crtl & CAN_ERR_CRTL_RX_OVERFLOW) != 0;
    e.tx_overflow = (crtl & CAN_ERR_CRTL_TX_OVERFLOW) != 0;
    e.error_warning = (crtl & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0;
    e.error_passive = (crtl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0;
    e.error_active_again = (crtl & CAN_ERR_CRTL_ACTIVE) != 0;
  }
  // Drivers fill data[6]/data[7] with the error counters when they set CAN_ERR_CNT (Linux 5.19+).
  e.has_counters = (e.classes & CAN_ERR_CNT) != 0;
  if (e.has_counters) {
    e.tx_error_count = data[6];
    e.rx_error_count = data[7];
  }
  return e;
}

std::string Describe(const CanErrorFrame& e) {
  std::string text;
  auto add = [&text](const char* what) {
    if (!text.empty()) text += ", ";
    text += what;
  };
  if (e.bus_off) add("bus-off");
  if (e.restarted) add("restarted");
  if (e.tx_timeout) add("tx timeout");
  if (e.no_ack) add("no ack");
  if (e.lost_arbitration) add("lost arbitration");
  if (e.bus_error) add("bus error");
  if (e.protocol_violation) add("protocol violation");
  if (e.transceiver) add("transceiver");
  if (e.error_passive) add("error passive");
  if (e.error_warning) add("error warning");
  if (e.error_active_again) add("error active again");
  if (e.rx_overflow) add("rx overflow");
  if (e.tx_overflow) add("tx overflow");
  if (e.controller && !e.error_passive && !e.error_warning && !e.error_active_again &&
      !e.rx_overflow && !e.tx_overflow)
    add("controller problem");
  if (e.has_counters)
    text += " (tx errors " + std::to_string(e.tx_error_count) + ", rx errors " +
            std::to_string(e.rx_error_count) + ")";
  if (text.empty()) text = "error frame " + CanIdText(e.classes);
  return text;
}

// ---------------------------------------------------------------------------------------------

CanRawSocket::~CanRawSocket() {
  if (fd_ >= 0) ::close(fd_);
}

bool CanRawSocket::Start(const CanRawConfig& config, int64_t now_us, std::string* error) {
  if (!config.IsValid(error)) return false;
  Stop();
  config_ = config;
  link_.Reset(config.reopen);
  link_.Due(now_us);
  TryOpen();
  return true;
}

void CanRawSocket::Stop() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
  link_.SetState(CanLinkState::kClosed);
}

void CanRawSocket::Tick(int64_t now_us) {
  if (link_.Due(now_us)) {
    TryOpen();
    return;
  }
  int err = 0;
  socklen_t len = sizeof(err);
  if (fd_ >= 0 && ::getsockopt(fd_, SOL_SOCKET, SO_ERROR, &err, &len) == 0 && err != 0 &&
      Fail(err, "pending socket error") == CanIo::kError)
    ++link_.counters().rx_errors;
}

void CanRawSocket::TryOpen() {
  int ifindex = 0;
  std::string error;
  const CanLinkState state = CheckCanInterface(config_.interface, &ifindex, nullptr, &error);
  if (state != CanLinkState::kUp) {
    link_.OpenFailed(state, std::move(error));
    return;
  }
  auto fail = [&](const char* what) {
    const int err = errno;
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    link_.OpenFailed(
        IsLinkErrno(err) ? CanLinkState::kDown : CanLinkState::kFailed,
        "raw CAN socket on " + config_.interface + ": " + what + ": " + std::strerror(err));
  };
  fd_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
  if (fd_ < 0) return fail("socket(PF_CAN, SOCK_RAW, CAN_RAW)");
  can_filter filters[CanRawConfig::kMaxFilters];
  for (size_t i = 0; i < config_.num_filters; ++i) {
    const CanRawFilter& f = config_.filters[i];
    const uint32_t eff = f.extended ? CAN_EFF_FLAG : 0U;
    filters[i].can_id = f.id | eff;
    // Compare the IDE bit too, and never match remote frames.
    filters[i].can_mask = f.mask | CAN_EFF_FLAG | CAN_RTR_FLAG;
  }
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_FILTER, config_.num_filters > 0 ? filters : nullptr,
                   static_cast<socklen_t>(config_.num_filters * sizeof(can_filter))) != 0)
    return fail("CAN_RAW_FILTER");
  const can_err_mask_t err_mask =
      config_.error_frames ? (CAN_ERR_TX_TIMEOUT | CAN_ERR_CRTL | CAN_ERR_TRX | CAN_ERR_ACK |
                              CAN_ERR_BUSOFF | CAN_ERR_RESTARTED | CAN_ERR_LOSTARB)
                           : 0U;
  if (::setsockopt(fd_, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0)
    return fail("CAN_RAW_ERR_FILTER");
  const int on = 1;
  if (::setsockopt(fd_, SOL_SOCKET, SO_TIMESTAMPNS, &on, sizeof(on)) != 0)
    return fail("SO_TIMESTAMPNS");
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) return fail("bind");
  link_.Opened();
}

CanIo CanRawSocket::Fail(int err, const char* what) {
  if (IsLinkErrno(err)) {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    link_.Lost(
        err == ENODEV || err == EADDRNOTAVAIL ? CanLinkState::kNoInterface : CanLinkState::kDown,
        "raw CAN on " + config_.interface + ": " + what + ": " + std::strerror(err));
    return CanIo::kLinkDown;
  }
  link_.SetError("raw CAN on " + config_.interface + ": " + what + ": " + std::strerror(err));
  return CanIo::kError;
}

CanIo CanRawSocket::Send(uint32_t id, bool extended, const uint8_t* data, size_t len) {
  if (fd_ < 0) return CanIo::kLinkDown;
  if (id > (extended ? CAN_EFF_MASK : CAN_SFF_MASK) || len > CAN_MAX_DLEN) {
    ++link_.counters().tx_errors;
    link_.SetError("raw CAN send: id " + CanIdText(id) + " or length " + std::to_string(len) +
                   " out of range");
    return CanIo::kError;
  }
  can_frame frame{};
  frame.can_id = id | (extended ? CAN_EFF_FLAG : 0U);
  frame.len = static_cast<uint8_t>(len);
  if (len > 0) std::memcpy(frame.data, data, len);
  const ssize_t sent = ::send(fd_, &frame, sizeof(frame), MSG_DONTWAIT);
  if (sent == static_cast<ssize_t>(sizeof(frame))) {
    ++link_.counters().tx_messages;
    if (link_.status().state == CanLinkState::kBusOff) link_.SetState(CanLinkState::kUp);
    return CanIo::kOk;
  }
  const int err = sent < 0 ? errno : EIO;
  if (err == ENOBUFS || err == EAGAIN) {
    ++link_.counters().tx_errors;
    return CanIo::kBusy;
  }
  const CanIo io = Fail(err, "send");
  if (io == CanIo::kError) ++link_.counters().tx_errors;
  return io;
}

CanIo CanRawSocket::Receive(CanFrame* out) {
  if (fd_ < 0) return CanIo::kLinkDown;
  can_frame frame{};
  iovec iov{&frame, sizeof(frame)};
  alignas(cmsghdr) char control[CMSG_SPACE(sizeof(timespec))];
  msghdr msg{};
  msg.msg_iov = &iov;
  msg.msg_iovlen = 1;
  msg.msg_control = control;
  msg.msg_controllen = sizeof(control);
  const ssize_t got = ::recvmsg(fd_, &msg, MSG_DONTWAIT);
  if (got < 0) {
    const int err = errno;
    if (err == EAGAIN || err == EINTR) return CanIo::kNone;
    const CanIo io = Fail(err, "recv");
    if (io == CanIo::kError) ++link_.counters().rx_errors;
    return io;
  }
  if (got != static_cast<ssize_t>(sizeof(frame))) {
    ++link_.counters().rx_errors;
    link_.SetError("raw CAN recv: " + std::to_string(got) + " bytes, not a classic frame");
    return CanIo::kError;
  }
  out->timestamp_ns = 0;
  for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
    if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMPNS) {
      timespec ts{};
      std::memcpy(&ts, CMSG_DATA(c), sizeof(ts));
      out->timestamp_ns = static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
    }
  }
  out->extended = (frame.can_id & CAN_EFF_FLAG) != 0;
  out->id = frame.can_id & (out->extended ? CAN_EFF_MASK : CAN_SFF_MASK);
  out->len = frame.len > CAN_MAX_DLEN ? CAN_MAX_DLEN : frame.len;
  std::memcpy(out->data.data(), frame.data, CAN_MAX_DLEN);
  if (frame.can_id & CAN_ERR_FLAG) {
    last_error_frame_ = DecodeCanErrorFrame(frame.can_id, out->data);
    ++link_.counters().error_frames;
    if (last_error_frame_.bus_off) {
      ++link_.counters().bus_off_events;
      link_.SetState(CanLinkState::kBusOff);
      link_.SetError("CAN " + config_.interface + ": " + Describe(last_error_frame_));
    } else if (last_error_frame_.restarted || last_error_frame_.error_active_again) {
      if (link_.status().state == CanLinkState::kBusOff) link_.SetState(CanLinkState::kUp);
    }
    return CanIo::kErrorFrame;
  }
  ++link_.counters().rx_messages;
  return CanIo::kOk;
}

}  // namespace calibd
