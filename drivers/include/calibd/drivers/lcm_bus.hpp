#pragma once
/// \file
/// RAII wrapper over liblcm for the agent's one poll loop: the file descriptor to poll, a bounded
/// Handle(), typed subscriptions whose messages are decoded here and typed publishing. liblcm
/// stays behind a pimpl: nothing from <lcm/...> appears in this header, only the lcm-gen message
/// types of the callers.
///
/// Transports (LCM URLs): `udpm://239.255.76.67:7667?ttl=0` (UDP multicast; ttl=0 keeps it on
/// this host), `memq://` (in-process queue of this object only: tests), `file://PATH?speed=0`
/// (replays a log as fast as Handle() is called, the way the agent replays recordings).
///
/// A message that does not decode as its channel's type is counted (per channel) and skipped,
/// never fatal. Channels of the registry (calibd/channels.hpp) only carry their registered type:
/// subscribing or publishing another type there is refused.
///
/// Queue capacity and drop policy (liblcm 1.3, lcm/lcm.c lcm_try_enqueue_message): each
/// subscription counts the messages received but not yet dispatched. While that count exceeds the
/// capacity, LCM drops each newly arriving message for the subscription: the newest is dropped,
/// the queued older ones are kept and dispatched in order. LCM compares with `<=`, so up to
/// capacity + 1 messages wait (tests/test_lcm_bus.cpp measures it). The bound acts only where a
/// receive thread queues ahead of Handle(): udpm (also tcpq, mpudpm). memq:// and file:// admit a
/// message at dispatch time and never drop: memq queues every publish, unbounded; file:// reads
/// the log only as fast as Handle() runs. liblcm 1.3 counts no drops: a dropped sensor frame is
/// visible only as a gap in its sender's capture times (the registry states each channel's rate).
/// Before LCM's queue, the kernel drops UDP fragments when its receive buffer overflows
/// (net.core.rmem_default; ask for more with `?recv_buf_size=BYTES`, up to net.core.rmem_max).
///
/// Threading: one thread (the poll loop) calls every method; handlers run inside Handle() on that
/// thread and must not call Open() or Close(). An exception escaping a handler would unwind
/// through liblcm's C code: it terminates the program instead (std::terminate).

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <utility>

#include "calibd/calibration_request_t.hpp"
#include "calibd/camera_frame_t.hpp"
#include "calibd/lidar_frame_t.hpp"

namespace calibd {

/// What one channel's subscription received.
struct LcmChannelCounters {
  int64_t received = 0;       ///< messages LCM dispatched to the subscription
  int64_t decode_errors = 0;  ///< of those, not exactly one message of the type: skipped
};

namespace lcm_bus_detail {

/// Type erasure for LcmBus::Subscribe: the raw LCM callback lives in lcm_bus.cpp and calls these.
class Decoder {
 public:
  virtual ~Decoder() = default;
  /// Decodes `size` bytes into the held message; false unless they are exactly one message of
  /// the type. May throw std::length_error or std::bad_alloc: lcm-gen's decode sizes its arrays
  /// from the counts it reads before checking the length left.
  virtual bool Decode(const void* data, int size) = 0;
  /// Passes the message of the last successful Decode to the handler.
  virtual void Deliver(int64_t recv_utime) = 0;
};

/// Whether the array counts in the `size` encoded bytes at `data` could be met by those bytes:
/// lcm-gen's decode resizes each array to the count it read (zero-filling it) before checking
/// that the bytes are there, so a 78-byte lidar_frame_t claiming 2^28 points made the agent fill
/// and keep ~1 GB (found by tests/fuzz/fuzz_lcm_lidar). False for a negative count or more
/// elements than bytes left, or a string length below 1 (decode computed `length - 1` in int:
/// undefined for INT32_MIN); true when the header is too short to tell (decode refuses it).
bool EncodedCountsFit(const calibration_request_t* type, const void* data, int size);
bool EncodedCountsFit(const camera_frame_t* type, const void* data, int size);
bool EncodedCountsFit(const lidar_frame_t* type, const void* data, int size);
/// Other types: no array sized by a count in calibd's messages, nothing to check.
inline bool EncodedCountsFit(const void*, const void*, int) { return true; }

template <typename Msg>
class TypedDecoder final : public Decoder {
 public:
  explicit TypedDecoder(std::function<void(const Msg&, int64_t)> handler)
      : handler_(std::move(handler)) {}
  bool Decode(const void* data, int size) override {
    return EncodedCountsFit(&msg_, data, size) && msg_.decode(data, 0, size) == size;
  }
  void Deliver(int64_t recv_utime) override { handler_(msg_, recv_utime); }

 private:
  std::function<void(const Msg&, int64_t)> handler_;
  Msg msg_;  ///< reused: its arrays keep their capacity from one message to the next
};

}  // namespace lcm_bus_detail

class LcmBus {
 public:
  /// liblcm's default URL, used when Open gets an empty URL and LCM_DEFAULT_URL is not set.
  static constexpr const char* kDefaultUrl = "udpm://239.255.76.67:7667?ttl=0";

  LcmBus();
  ~LcmBus();
  LcmBus(const LcmBus&) = delete;
  LcmBus& operator=(const LcmBus&) = delete;

  /// Creates the LCM instance for `url`; an empty URL means the environment's LCM_DEFAULT_URL or
  /// else kDefaultUrl (liblcm's own rule). Also sets up the receive side, so that a udpm group
  /// that cannot be joined fails here (liblcm's self-test waits up to 10 s) rather than in
  /// Subscribe. False with `error` naming the URL and what is wrong (malformed URL, unknown
  /// provider, log file that cannot be opened, multicast not reachable). Drops any earlier state.
  bool Open(const std::string& url, std::string* error);
  /// Releases the LCM instance and every subscription. Open() may be called again.
  void Close();

  bool is_open() const;
  /// The URL in use (empty URL resolved); empty when not open.
  const std::string& url() const;
  /// A file:// log is replayed: read at its own pace, and not writable.
  bool is_replay() const { return url().rfind("file://", 0) == 0; }
  /// Becomes readable when a message is ready for Handle(); -1 when not open. Stays the same
  /// until Close().
  int fileno() const;

  /// Waits up to `timeout_ms` (>= 0; 0: do not wait) for a message, dispatches it, then the
  /// messages already waiting, at most `max_messages` in all: a flood, or a file:// replay at
  /// speed=0 (always ready), cannot starve the poll loop's other inputs. Returns the number of
  /// messages dispatched (> 0), 0 when none came within the timeout, < 0 when the transport
  /// failed or, for a file:// log, when the log ended (see end_of_log()).
  int Handle(int timeout_ms, int max_messages = 64);
  /// A file:// log was read to its end (or to an unreadable event); may turn true during a call
  /// that still returns > 0. From then on Handle() returns < 0 and fileno() stays readable, so the
  /// poll loop should stop watching it.
  bool end_of_log() const;

  /// Subscribes `handler` to `channel` with at most `queue_capacity` (>= 1) messages waiting
  /// (see the drop policy above). Each message is decoded here into one reused `Msg` and passed
  /// with its receive time `recv_utime` (udpm: kernel receive time, memq: publish time, file://:
  /// the replay's wall clock, not the log's event time; pair frames by their own capture times).
  /// One subscription per channel. False with `error` when not open, the channel name is not a
  /// plain name (LCM subscribes by regular expression), the registry gives the channel another
  /// type, the channel is already subscribed, or the capacity is < 1.
  template <typename Msg>
  bool Subscribe(std::string_view channel, int queue_capacity,
                 std::function<void(const Msg&, int64_t recv_utime)> handler, std::string* error) {
    return SubscribeDecoder(channel, Msg::getTypeName(), queue_capacity,
                            std::make_unique<lcm_bus_detail::TypedDecoder<Msg>>(std::move(handler)),
                            error);
  }

  /// Encodes `msg` (into a buffer reused between calls) and publishes it. False with `error` when
  /// not open, the registry gives the channel another type, or the transport refused it (e.g. a
  /// file:// log opened for reading).
  template <typename Msg>
  bool Publish(std::string_view channel, const Msg& msg, std::string* error) {
    if (!CheckType(channel, Msg::getTypeName(), error)) return false;
    const int size = msg.getEncodedSize();
    uint8_t* buffer = EncodeBuffer(static_cast<size_t>(size));
    if (msg.encode(buffer, 0, size) != size) {
      if (error)
        *error = "LCM encode of " + std::string(Msg::getTypeName()) + " failed on channel " +
                 std::string(channel);
      return false;
    }
    return PublishRaw(channel, buffer, static_cast<size_t>(size), error);
  }

  /// Publishes bytes as they are (no type check), e.g. to relay a recorded event.
  bool PublishRaw(std::string_view channel, const void* data, size_t size, std::string* error);

  /// Counters of `channel`'s subscription; zeros when it is not subscribed.
  LcmChannelCounters counters(std::string_view channel) const;
  /// Messages that did not decode, all channels together.
  int64_t decode_errors() const;

 private:
  struct Channel;
  struct Impl;
  bool SubscribeDecoder(std::string_view channel, const char* type_name, int queue_capacity,
                        std::unique_ptr<lcm_bus_detail::Decoder> decoder, std::string* error);
  /// False with `error` when the registry gives `channel` a type other than `type_name`.
  static bool CheckType(std::string_view channel, const char* type_name, std::string* error);
  uint8_t* EncodeBuffer(size_t size);

  std::unique_ptr<Impl> impl_;
};

}  // namespace calibd
