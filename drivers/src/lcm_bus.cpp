#include "calibd/drivers/lcm_bus.hpp"

#include <lcm/lcm-cpp.hpp>

#include <algorithm>
#include <array>
#include <climits>
#include <cstdlib>
#include <exception>
#include <vector>

#include "calibd/channels.hpp"

namespace calibd {

namespace lcm_bus_detail {

namespace {

// Reads the encoded message's head up to its count field, as lcm-gen lays it out: 8-byte type
// fingerprint, then the fields in order, integers big-endian, strings as int32 length (with the
// NUL) and bytes. `pos` advances; false when the bytes end first.
class HeadReader {
 public:
  HeadReader(const void* data, int size)
      : d_(static_cast<const uint8_t*>(data)), n_(size < 0 ? 0 : static_cast<size_t>(size)) {}
  bool Skip(size_t bytes) {
    if (n_ - pos_ < bytes) return false;
    pos_ += bytes;
    return true;
  }
  bool Int32(int32_t* v) {
    if (n_ - pos_ < 4) return false;
    const uint32_t u = uint32_t{d_[pos_]} << 24 | uint32_t{d_[pos_ + 1]} << 16 |
                       uint32_t{d_[pos_ + 2]} << 8 | uint32_t{d_[pos_ + 3]};
    pos_ += 4;
    *v = static_cast<int32_t>(u);
    return true;
  }
  // lcm-gen's decode computes `length - 1` in int (overflow for INT32_MIN) and assigns that many
  // chars: a length below 1 is malformed, not just short.
  bool String() {
    int32_t length = 0;
    if (!Int32(&length)) return false;
    if (length < 1) bad_ = true;
    return !bad_ && Skip(static_cast<size_t>(length));
  }
  bool bad() const { return bad_; }
  size_t left() const { return n_ - pos_; }

 private:
  const uint8_t* d_;
  size_t n_, pos_ = 0;
  bool bad_ = false;
};

// `count` elements of `bytes_each` bytes fit in what is left.
bool CountFits(int32_t count, size_t bytes_each, size_t left) {
  return count >= 0 && static_cast<size_t>(count) <= left / bytes_each;
}

}  // namespace

}  // namespace lcm_bus_detail

bool lcm_bus_detail::EncodedCountsFit(const camera_frame_t*, const void* data, int size) {
  HeadReader r(data, size);
  int32_t count = 0;
  // fingerprint, utime, camera_id, width, height, stride (int32), encoding (int8), size
  if (!r.Skip(16) || !r.String() || !r.Skip(4 + 4 + 4 + 1) || !r.Int32(&count)) return !r.bad();
  return CountFits(count, 1, r.left());
}

bool lcm_bus_detail::EncodedCountsFit(const calibration_request_t*, const void* data, int size) {
  HeadReader r(data, size);
  // fingerprint, utime, action, mode (int8), max_duration_ms, requester
  if (r.Skip(16 + 1 + 1 + 4)) r.String();
  return !r.bad();
}

bool lcm_bus_detail::EncodedCountsFit(const lidar_frame_t*, const void* data, int size) {
  HeadReader r(data, size);
  int32_t count = 0;
  // fingerprint, utime, lidar_id, num_points; then per point x y z intensity (float), ring
  // (int16), time_offset_us (int32).
  if (!r.Skip(16) || !r.String() || !r.Int32(&count)) return !r.bad();
  return CountFits(count, 4 * 4 + 2 + 4, r.left());
}

struct LcmBus::Channel {
  std::string name;
  std::unique_ptr<lcm_bus_detail::Decoder> decoder;
  LcmChannelCounters counters;
};

struct LcmBus::Impl {
  std::string url;
  int fd = -1;
  bool log_reader = false;  ///< file:// opened for reading: a failing handle means end of log
  bool end_of_log = false;
  // Declared before `lcm` so that they outlive it: LCM holds raw pointers to them as contexts.
  std::vector<std::unique_ptr<Channel>> channels;
  std::unique_ptr<lcm::LCM> lcm;
  std::vector<uint8_t> encode_buffer;
  std::string publish_channel;  ///< lcm::LCM::publish takes a std::string: reused, no allocation
};

namespace {

// The providers liblcm 1.3 registers (lcm.c, lcm_create).
constexpr std::array<std::string_view, 5> kProviders{"udpm", "mpudpm", "tcpq", "memq", "file"};

// LCM_MAX_CHANNEL_NAME_LENGTH in lcm.h; udpm refuses longer names.
constexpr size_t kMaxChannelName = 63;

// LCM subscribes with the regular expression "^channel$": only names without regex
// metacharacters match exactly themselves (and cannot fail to compile).
bool CheckChannelName(std::string_view channel, std::string* error) {
  auto fail = [&](const std::string& what) {
    if (error) *error = "LCM channel '" + std::string(channel) + "': " + what;
    return false;
  };
  if (channel.empty()) return fail("must not be empty");
  if (channel.size() > kMaxChannelName)
    return fail("longer than " + std::to_string(kMaxChannelName) + " characters");
  for (const char c : channel) {
    const bool plain = (c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                       c == '_' || c == '-' || c == '/';
    if (!plain)
      return fail(
          "only letters, digits, '_', '-' and '/' are allowed (LCM subscribes by regular "
          "expression)");
  }
  return true;
}

// The message behind `rbuf` for `channel`: decoded and delivered, or counted and skipped.
// noexcept: an exception must not unwind through liblcm's C frames (std::terminate instead).
// lcm-cpp passes the channel name as a std::string built per message: no allocation for names of
// up to 15 characters (small-string buffer), which covers the camera and LiDAR channels.
template <typename ChannelT>
void OnRawMessage(const lcm::ReceiveBuffer* rbuf, const std::string& /*channel*/,
                  ChannelT* channel) noexcept {
  ++channel->counters.received;
  bool decoded = false;
  if (rbuf->data_size <= static_cast<uint32_t>(INT_MAX)) {
    try {
      decoded = channel->decoder->Decode(rbuf->data, static_cast<int>(rbuf->data_size));
    } catch (const std::exception&) {
      decoded = false;  // a count in the message asked for an absurd array: malformed
    }
  }
  if (!decoded) {
    ++channel->counters.decode_errors;
    return;
  }
  channel->decoder->Deliver(rbuf->recv_utime);
}

}  // namespace

LcmBus::LcmBus() : impl_(std::make_unique<Impl>()) {}
LcmBus::~LcmBus() { Close(); }

bool LcmBus::Open(const std::string& url, std::string* error) {
  Close();
  std::string resolved = url;
  if (resolved.empty()) {
    const char* env = std::getenv("LCM_DEFAULT_URL");
    resolved = (env && *env) ? env : kDefaultUrl;
  }
  auto fail = [&](const std::string& what) {
    if (error) *error = "LCM URL '" + resolved + "': " + what;
    Close();
    return false;
  };
  // liblcm reports these on stderr only; say them here so the caller's log has them.
  const size_t sep = resolved.find("://");
  if (sep == std::string::npos || sep == 0)
    return fail("malformed, expected provider://network?options (e.g. " + std::string(kDefaultUrl) +
                ")");
  const std::string provider = resolved.substr(0, sep);
  if (std::find(kProviders.begin(), kProviders.end(), provider) == kProviders.end())
    return fail("unknown provider '" + provider + "' (liblcm has udpm, mpudpm, tcpq, memq, file)");
  const std::string rest = resolved.substr(sep + 3);
  const std::string target = rest.substr(0, rest.find('?'));
  const std::string options = rest.size() > target.size() ? rest.substr(target.size() + 1) : "";
  const bool log_writer = provider == "file" && (options.find("mode=w") != std::string::npos ||
                                                 options.find("mode=a") != std::string::npos);

  auto instance = std::make_unique<lcm::LCM>(resolved);
  if (!instance->good()) {
    if (provider == "file")
      return fail("cannot open the LCM log '" + target + "' (missing, unreadable or not a log)");
    if (provider == "udpm" || provider == "mpudpm")
      return fail(
          "cannot create the multicast transport (bad group address or port, or no route "
          "to the group; liblcm printed the details)");
    return fail("liblcm cannot create it (it printed the reason)");
  }
  // For udpm this creates the receive thread and runs liblcm's self-test, so that a host without
  // a route to the group fails now, not later inside lcm::LCM::subscribeFunction (which would
  // return a subscription with a null handle that setQueueCapacity dereferences).
  const int fd = instance->getFileno();
  if (fd < 0)
    return fail(
        "cannot receive (udpm: the multicast self-test failed; check the route to the "
        "group and the firewall)");
  impl_->lcm = std::move(instance);
  impl_->url = resolved;
  impl_->fd = fd;
  impl_->log_reader = provider == "file" && !log_writer;
  impl_->end_of_log = false;
  return true;
}

void LcmBus::Close() {
  impl_->lcm.reset();  // first: it holds pointers to the channels
  impl_->channels.clear();
  impl_->url.clear();
  impl_->fd = -1;
  impl_->log_reader = impl_->end_of_log = false;
}

bool LcmBus::is_open() const { return impl_->lcm != nullptr; }
const std::string& LcmBus::url() const { return impl_->url; }
int LcmBus::fileno() const { return impl_->fd; }
bool LcmBus::end_of_log() const { return impl_->end_of_log; }

int LcmBus::Handle(int timeout_ms, int max_messages) {
  if (!impl_->lcm) return -1;
  int handled = 0;
  for (int timeout = std::max(timeout_ms, 0); handled < std::max(max_messages, 1); timeout = 0) {
    const int status = impl_->lcm->handleTimeout(timeout);
    if (status < 0) {
      // The file provider fails every handle after its last event (lcm_logprov_handle).
      if (impl_->log_reader) impl_->end_of_log = true;
      return handled > 0 ? handled : status;
    }
    if (status == 0) break;
    ++handled;
  }
  return handled;
}

bool LcmBus::CheckType(std::string_view channel, const char* type_name, std::string* error) {
  const ChannelSpec* spec = FindChannel(channel);
  if (spec == nullptr) return true;
  // The registry names types package-qualified ("calibd.camera_frame_t"), lcm-gen without.
  const size_t dot = spec->type.rfind('.');
  const std::string_view registered =
      dot == std::string_view::npos ? spec->type : spec->type.substr(dot + 1);
  if (registered == type_name) return true;
  if (error)
    *error = "LCM channel '" + std::string(channel) + "' carries " + std::string(spec->type) +
             ", not " + type_name;
  return false;
}

bool LcmBus::SubscribeDecoder(std::string_view channel, const char* type_name, int queue_capacity,
                              std::unique_ptr<lcm_bus_detail::Decoder> decoder,
                              std::string* error) {
  if (!impl_->lcm) {
    if (error) *error = "LCM bus is not open (subscribing to " + std::string(channel) + ")";
    return false;
  }
  if (!CheckChannelName(channel, error) || !CheckType(channel, type_name, error)) return false;
  if (queue_capacity < 1) {
    if (error)
      *error = "LCM channel '" + std::string(channel) + "': queue capacity must be >= 1 (got " +
               std::to_string(queue_capacity) + ")";
    return false;
  }
  for (const auto& c : impl_->channels) {
    if (c->name == channel) {
      if (error) *error = "LCM channel '" + std::string(channel) + "' is already subscribed";
      return false;
    }
  }
  auto entry = std::make_unique<Channel>();
  entry->name = std::string(channel);
  entry->decoder = std::move(decoder);
  lcm::Subscription* subscription =
      impl_->lcm->subscribeFunction<Channel*>(entry->name, &OnRawMessage<Channel>, entry.get());
  if (subscription == nullptr) {
    if (error) *error = "LCM refused the subscription to '" + entry->name + "'";
    return false;
  }
  subscription->setQueueCapacity(queue_capacity);
  impl_->channels.push_back(std::move(entry));
  return true;
}

bool LcmBus::PublishRaw(std::string_view channel, const void* data, size_t size,
                        std::string* error) {
  if (!impl_->lcm) {
    if (error) *error = "LCM bus is not open (publishing on " + std::string(channel) + ")";
    return false;
  }
  if (!CheckChannelName(channel, error)) return false;
  if (size > static_cast<size_t>(UINT_MAX)) {
    if (error) *error = "LCM message on " + std::string(channel) + " is too large";
    return false;
  }
  impl_->publish_channel.assign(channel.data(), channel.size());
  if (impl_->lcm->publish(impl_->publish_channel, data, static_cast<unsigned int>(size)) != 0) {
    if (error) *error = "LCM publish on " + impl_->publish_channel + " failed (" + impl_->url + ")";
    return false;
  }
  return true;
}

LcmChannelCounters LcmBus::counters(std::string_view channel) const {
  for (const auto& c : impl_->channels)
    if (c->name == channel) return c->counters;
  return {};
}

int64_t LcmBus::decode_errors() const {
  int64_t n = 0;
  for (const auto& c : impl_->channels) n += c->counters.decode_errors;
  return n;
}

uint8_t* LcmBus::EncodeBuffer(size_t size) {
  if (impl_->encode_buffer.size() < size) impl_->encode_buffer.resize(size);
  return impl_->encode_buffer.data();
}

}  // namespace calibd
