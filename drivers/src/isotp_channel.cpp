#include "calibd/drivers/isotp_channel.hpp"

#include <linux/can.h>
#include <linux/can/isotp.h>
#include <net/if.h>
#include <sys/socket.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "calibd/core/common/validation.hpp"

namespace calibd {
namespace {

bool ValidStMin(uint8_t st_min) { return st_min <= 0x7F || (st_min >= 0xF1 && st_min <= 0xF9); }

bool ValidFdTxDl(uint8_t dl) {
  for (const int valid : {8, 12, 16, 20, 24, 32, 48, 64})
    if (dl == valid) return true;
  return false;
}

}  // namespace

const char* ToString(IsoTpIo io) {
  switch (io) {
    case IsoTpIo::kOk:
      return "ok";
    case IsoTpIo::kNone:
      return "none";
    case IsoTpIo::kBusy:
      return "busy";
    case IsoTpIo::kLinkDown:
      return "link_down";
    case IsoTpIo::kError:
      return "error";
  }
  return "unknown";
}

bool IsoTpConfig::IsValid(std::string* error) const {
  if (!CanInterfaceNameValid(interface, error)) return false;
  const uint32_t max_id = extended_ids ? CAN_EFF_MASK : CAN_SFF_MASK;
  const char* bits = extended_ids ? "29" : "11";
  const struct {
    const char* key;
    uint32_t id;
  } ids[] = {{"physical_request_id", physical_request_id},
             {"physical_response_id", physical_response_id},
             {"functional_request_id", functional_request_id}};
  for (const auto& id : ids)
    if (id.id > max_id)
      return Invalid(error, std::string(id.key) + ": " + CanIdText(id.id) + " does not fit in " +
                                bits + " bits");
  if (physical_request_id == physical_response_id ||
      functional_request_id == physical_response_id || functional_request_id == physical_request_id)
    return Invalid(
        error, "physical_request_id, physical_response_id and functional_request_id must differ (" +
                   CanIdText(physical_request_id) + ", " + CanIdText(physical_response_id) + ", " +
                   CanIdText(functional_request_id) + ")");
  if (!ValidStMin(st_min))
    return Invalid(error, "st_min: " + CanIdText(st_min) +
                              " is reserved (0x00-0x7F ms or 0xF1-0xF9 100-900 us)");
  if (can_fd && !ValidFdTxDl(fd_tx_dl))
    return Invalid(error, "fd_tx_dl: " + std::to_string(fd_tx_dl) +
                              " is not a CAN FD length (8, 12, 16, 20, 24, 32, 48, 64)");
  std::string reopen_error;
  if (!reopen.IsValid(&reopen_error)) return Invalid(error, reopen_error);
  return true;
}

// ---------------------------------------------------------------------------------------------

IsoTpSocket::~IsoTpSocket() { Close(); }

void IsoTpSocket::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

bool IsoTpSocket::Open(const IsoTpConfig& config, int ifindex, uint32_t tx_id, uint32_t rx_id,
                       Mode mode, std::string* error, int* err) {
  Close();
  auto fail = [&](const char* what) {
    *err = errno;
    if (error)
      *error = "ISO-TP socket " + CanIdText(tx_id) + "/" + CanIdText(rx_id) + " on " +
               config.interface + ": " + what + ": " + std::strerror(*err);
    Close();
    return false;
  };
  fd_ = ::socket(PF_CAN, SOCK_DGRAM | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_ISOTP);
  // A kernel without its can-isotp module (in mainline Linux since 5.10) knows no such protocol:
  // say what to load rather than only "Protocol not supported".
  if (fd_ < 0 && errno == EPROTONOSUPPORT)
    return fail(
        "socket(PF_CAN, SOCK_DGRAM, CAN_ISOTP): the kernel's ISO-TP module is not "
        "loaded (as root: modprobe can-isotp)");
  if (fd_ < 0) return fail("socket(PF_CAN, SOCK_DGRAM, CAN_ISOTP)");

  // Options must be set before bind (the kernel refuses them on a bound socket with EISCONN).
  can_isotp_options opts{};
  opts.frame_txtime = CAN_ISOTP_DEFAULT_FRAME_TXTIME;
  opts.ext_address = CAN_ISOTP_DEFAULT_EXT_ADDRESS;
  opts.txpad_content = config.pad_byte;
  opts.rxpad_content = config.pad_byte;
  if (config.padding) opts.flags |= CAN_ISOTP_TX_PADDING | CAN_ISOTP_RX_PADDING;
  if (config.forced_tx_st_min_ns > 0) opts.flags |= CAN_ISOTP_FORCE_TXSTMIN;
  if (mode == Mode::kListenOnly) opts.flags |= CAN_ISOTP_LISTEN_MODE;
  if (mode == Mode::kBroadcastTx) opts.flags |= CAN_ISOTP_SF_BROADCAST;
  if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_OPTS, &opts, sizeof(opts)) != 0)
    return fail("CAN_ISOTP_OPTS");

  can_isotp_fc_options fc{};
  fc.bs = config.block_size;
  fc.stmin = config.st_min;
  fc.wftmax = config.wait_frames_max;
  if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_RECV_FC, &fc, sizeof(fc)) != 0)
    return fail("CAN_ISOTP_RECV_FC");

  if (config.forced_tx_st_min_ns > 0) {
    const uint32_t ns = config.forced_tx_st_min_ns;
    if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_TX_STMIN, &ns, sizeof(ns)) != 0)
      return fail("CAN_ISOTP_TX_STMIN");
  }

  if (config.can_fd) {
    can_isotp_ll_options ll{};
    ll.mtu = CANFD_MTU;
    ll.tx_dl = config.fd_tx_dl;
    ll.tx_flags = 0;
    if (::setsockopt(fd_, SOL_CAN_ISOTP, CAN_ISOTP_LL_OPTS, &ll, sizeof(ll)) != 0)
      return fail("CAN_ISOTP_LL_OPTS (CAN FD)");
  }

  const uint32_t eff = config.extended_ids ? CAN_EFF_FLAG : 0U;
  sockaddr_can addr{};
  addr.can_family = AF_CAN;
  addr.can_ifindex = ifindex;
  addr.can_addr.tp.tx_id = tx_id | eff;
  addr.can_addr.tp.rx_id = rx_id | eff;
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) return fail("bind");
  return true;
}

// ---------------------------------------------------------------------------------------------

namespace isotp_detail {

bool TransportBase::StartBase(const IsoTpConfig& config, int64_t now_us, std::string* error) {
  if (!config.IsValid(error)) return false;
  CloseSockets();
  config_ = config;
  link_.Reset(config.reopen);
  link_.Due(now_us);
  TryOpen();
  return true;
}

void TransportBase::CloseSockets() {
  physical_.Close();
  functional_.Close();
}

void TransportBase::TickBase(int64_t now_us) {
  if (link_.Due(now_us)) {
    TryOpen();
    return;
  }
  if (!link_.up()) return;
  for (IsoTpSocket* socket : {&physical_, &functional_}) {
    int err = 0;
    socklen_t len = sizeof(err);
    if (socket->fd() < 0 || ::getsockopt(socket->fd(), SOL_SOCKET, SO_ERROR, &err, &len) != 0 ||
        err == 0)
      continue;
    if (Fail(err, "pending socket error", false) == IsoTpIo::kLinkDown) return;
  }
}

void TransportBase::TryOpen() {
  int ifindex = 0;
  int mtu = 0;
  std::string error;
  const CanLinkState state = CheckCanInterface(config_.interface, &ifindex, &mtu, &error);
  if (state != CanLinkState::kUp) {
    link_.OpenFailed(state, std::move(error));
    return;
  }
  if (config_.can_fd && mtu != CANFD_MTU) {
    link_.OpenFailed(CanLinkState::kFailed, "CAN interface " + config_.interface + " has MTU " +
                                                std::to_string(mtu) + ": CAN FD needs " +
                                                std::to_string(CANFD_MTU));
    return;
  }
  int err = 0;
  if (!OpenSockets(ifindex, &error, &err)) {
    CloseSockets();
    link_.OpenFailed(IsLinkErrno(err) ? CanLinkState::kDown : CanLinkState::kFailed,
                     std::move(error));
    return;
  }
  link_.Opened();
}

IsoTpIo TransportBase::Fail(int err, const char* what, bool sending) {
  if (IsLinkErrno(err)) {
    CloseSockets();
    link_.Lost(
        err == ENODEV || err == EADDRNOTAVAIL ? CanLinkState::kNoInterface : CanLinkState::kDown,
        "ISO-TP on " + config_.interface + ": " + what + ": " + std::strerror(err));
    return IsoTpIo::kLinkDown;
  }
  // ECOMM: an earlier transfer of ours got no flow control within N_Bs (1 s); ETIMEDOUT: a
  // message being received stopped (no consecutive frame within N_Cr, 1 s); EILSEQ: wrong
  // sequence number; EBADMSG: bad padding or PCI. The link stays up.
  if (sending || err == ECOMM)
    ++link_.counters().tx_errors;
  else
    ++link_.counters().rx_errors;
  link_.SetError("ISO-TP on " + config_.interface + ": " + what + ": " + std::strerror(err));
  return IsoTpIo::kError;
}

IsoTpIo TransportBase::SendOn(IsoTpSocket& socket, const uint8_t* data, size_t size) {
  if (!link_.up() || socket.fd() < 0) return IsoTpIo::kLinkDown;
  if (size == 0 || size > kIsoTpMaxMessage) {
    ++link_.counters().tx_errors;
    link_.SetError("ISO-TP send: " + std::to_string(size) + " bytes (1-" +
                   std::to_string(kIsoTpMaxMessage) + " allowed)");
    return IsoTpIo::kError;
  }
  const ssize_t sent = ::send(socket.fd(), data, size, MSG_DONTWAIT);
  if (sent == static_cast<ssize_t>(size)) {
    ++link_.counters().tx_messages;
    return IsoTpIo::kOk;
  }
  const int err = sent < 0 ? errno : EIO;
  if (err == EAGAIN || err == EBUSY) return IsoTpIo::kBusy;
  return Fail(err, "send", true);
}

IsoTpIo TransportBase::ReceiveOn(IsoTpSocket& socket, IsoTpMessage* out) {
  if (!link_.up() || socket.fd() < 0) return IsoTpIo::kLinkDown;
  const ssize_t got = ::recv(socket.fd(), buffer_.data(), buffer_.size(), MSG_DONTWAIT);
  if (got < 0) {
    const int err = errno;
    if (err == EAGAIN || err == EINTR) return IsoTpIo::kNone;
    return Fail(err, "recv", false);
  }
  if (got == 0 || static_cast<size_t>(got) > kIsoTpMaxMessage) {
    ++link_.counters().rx_errors;
    link_.SetError("ISO-TP recv: message of " + std::to_string(got) + " bytes skipped");
    return IsoTpIo::kError;
  }
  ++link_.counters().rx_messages;
  out->data = buffer_.data();
  out->size = static_cast<size_t>(got);
  out->functional = false;
  return IsoTpIo::kOk;
}

}  // namespace isotp_detail

// ---------------------------------------------------------------------------------------------

UdsServerTransport::~UdsServerTransport() { CloseSockets(); }

bool UdsServerTransport::Start(const IsoTpConfig& config, int64_t now_us, std::string* error) {
  return StartBase(config, now_us, error);
}

void UdsServerTransport::Stop() {
  CloseSockets();
  link_.SetState(CanLinkState::kClosed);
}

bool UdsServerTransport::OpenSockets(int ifindex, std::string* error, int* err) {
  return physical_.Open(config_, ifindex, config_.physical_response_id, config_.physical_request_id,
                        IsoTpSocket::Mode::kNormal, error, err) &&
         functional_.Open(config_, ifindex, config_.physical_response_id,
                          config_.functional_request_id, IsoTpSocket::Mode::kListenOnly, error,
                          err);
}

IsoTpIo UdsServerTransport::Receive(IsoTpMessage* out) {
  IsoTpIo io = ReceiveOn(physical_, out);
  if (io != IsoTpIo::kNone) return io;
  io = ReceiveOn(functional_, out);
  if (io == IsoTpIo::kOk) out->functional = true;
  return io;
}

IsoTpIo UdsServerTransport::Send(const uint8_t* data, size_t size) {
  return SendOn(physical_, data, size);
}

// ---------------------------------------------------------------------------------------------

UdsClientTransport::~UdsClientTransport() { CloseSockets(); }

bool UdsClientTransport::Start(const IsoTpConfig& config, int64_t now_us, std::string* error) {
  return StartBase(config, now_us, error);
}

void UdsClientTransport::Stop() {
  CloseSockets();
  link_.SetState(CanLinkState::kClosed);
}

bool UdsClientTransport::OpenSockets(int ifindex, std::string* error, int* err) {
  // The functional socket receives nothing (SF_BROADCAST registers no receiver); its rx id only
  // has to be a valid one.
  return physical_.Open(config_, ifindex, config_.physical_request_id, config_.physical_response_id,
                        IsoTpSocket::Mode::kNormal, error, err) &&
         functional_.Open(config_, ifindex, config_.functional_request_id,
                          config_.physical_response_id, IsoTpSocket::Mode::kBroadcastTx, error,
                          err);
}

IsoTpIo UdsClientTransport::SendPhysical(const uint8_t* data, size_t size) {
  return SendOn(physical_, data, size);
}

IsoTpIo UdsClientTransport::SendFunctional(const uint8_t* data, size_t size) {
  return SendOn(functional_, data, size);
}

IsoTpIo UdsClientTransport::Receive(IsoTpMessage* out) { return ReceiveOn(physical_, out); }

}  // namespace calibd
