#pragma once
/// @file heartbeat.hpp
/// CANopen heartbeat error control (CiA 301 §7.2.8.3.2.2 heartbeat protocol, §7.2.8.3.2.3
/// boot-up protocol):
///  - the heartbeat message, COB-ID 0x700 + node id, 1 byte: the producer's NMT state
///    (NmtState; 0x00 is the boot-up message);
///  - HeartbeatProducer: sends it every producer heartbeat time (object 1017h);
///  - HeartbeatConsumer: watches one node against a consumer heartbeat time (object 1016h);
///  - HeartbeatMonitor<N>: up to N consumers, frames routed by COB-ID.
/// Times are int64 ns on one monotonic clock (the bus clock of CanFrame::timestamp_ns).
/// Pure protocol logic: no I/O; everything but the constructors and HeartbeatMonitor::add()
/// is noexcept and allocation free. See docs/protocol.md.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <stdexcept>
#include <string>

#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/canopen/canopen.hpp"
#include "numen/hal/canopen/nmt.hpp"

namespace numen::hal {

/// Base COB-ID of the heartbeat / boot-up message (0x700 + node id; CiA 301 §7.2.8.3.2).
inline constexpr std::uint32_t kHeartbeatBaseCobId = 0x700;
/// Payload length of the heartbeat message, bytes.
inline constexpr std::uint8_t kHeartbeatLen = 1;

/// Heartbeat COB-ID of a node: 0x700 + node_id (node_id 1–127).
constexpr std::uint32_t heartbeat_cob_id(std::uint8_t node_id) noexcept {
  return kHeartbeatBaseCobId + node_id;
}

/// Heartbeat time as stored in objects 1016h / 1017h (u16, ms; 0 = disabled) in ns.
constexpr std::int64_t heartbeat_ms_to_ns(std::uint16_t ms) noexcept {
  return static_cast<std::int64_t>(ms) * 1'000'000;
}

/// Outcome of decoding a heartbeat message (decode_heartbeat()).
enum class HeartbeatDecodeStatus : std::uint8_t {
  kOk,            ///< Decoded.
  kWrongId,       ///< COB-ID is not 0x701–0x77F: not a heartbeat.
  kNotDataFrame,  ///< Heartbeat COB-ID but remote (a node-guarding request) or CAN FD frame.
                  ///< (Error reports and 29-bit frames are not on it: kWrongId.)
  kWrongLength,   ///< Payload length is not 1.
  kUnknownState,  ///< The state byte is not 0x00, 0x04, 0x05 or 0x7F (bit 7 set included).
};

/// Short English name of a HeartbeatDecodeStatus (static string).
const char* to_string(HeartbeatDecodeStatus status) noexcept;

/// Builds the heartbeat message of node `node_id` (1–127) reporting `state`, stamped
/// `timestamp_ns`: COB-ID 0x700 + node id, 1 byte = state. `state` kBootUp gives the boot-up
/// message. Returns false and leaves `out` unchanged if `node_id` is 0 or above 127 or
/// `state` is not an NmtState. Example: node 3 operational -> id 0x703, data 05.
bool encode_heartbeat(std::uint8_t node_id, NmtState state, std::int64_t timestamp_ns,
                      CanFrame& out) noexcept;

/// Decodes a heartbeat message into `node_id` and `state` (both unchanged unless kOk).
/// Checks, in order: COB-ID 0x701–0x77F (kWrongId); 11-bit classic data frame
/// (kNotDataFrame); length exactly 1 (kWrongLength); state byte (kUnknownState).
HeartbeatDecodeStatus decode_heartbeat(const CanFrame& frame, std::uint8_t& node_id,
                                       NmtState& state) noexcept;

/// Heartbeat producer of one node (CiA 301 §7.2.8.3.2.2; producer heartbeat time, object
/// 1017h). After start(t0) it is due at t0 + k·period for k = 1, 2, ...: on a fixed grid, so
/// the frames do not drift however the poll times fall. A poll that finds several grid points
/// passed (the caller was late) sends one frame and moves on to the next grid point after
/// `now`. Period 0 disables the producer.
class HeartbeatProducer {
 public:
  /// Producer for node `node_id` (1–127) with heartbeat period `period_ns` (>= 0; 0 =
  /// disabled). Not started. Throws std::invalid_argument naming the value if node_id is 0
  /// or above 127, or period_ns is negative.
  HeartbeatProducer(std::uint8_t node_id, std::int64_t period_ns);

  /// Starts (or restarts) production at `now_ns`, normally the time of the boot-up message:
  /// the first heartbeat is due at now_ns + period (CiA 301: production starts after the
  /// boot-up message).
  void start(std::int64_t now_ns) noexcept;
  /// Stops production until the next start() (e.g. while the node is in initialisation).
  void stop() noexcept { started_ = false; }

  /// Changes the period (object 1017h written at run time). The new period counts from the
  /// last heartbeat sent (or from start()). Returns false, and changes nothing, if
  /// `period_ns` is negative.
  bool set_period(std::int64_t period_ns) noexcept;

  /// If started, enabled and a heartbeat is due at `now_ns` (now_ns >= due time): writes the
  /// heartbeat reporting `state`, stamped `now_ns`, into `out`, schedules the next one and
  /// returns true. Otherwise returns false and leaves `out` unchanged. A `now_ns` earlier than
  /// a previous one sends nothing and changes nothing.
  bool poll(std::int64_t now_ns, NmtState state, CanFrame& out) noexcept;

  /// The node id.
  std::uint8_t node_id() const noexcept { return node_id_; }
  /// The period, ns (0 = disabled).
  std::int64_t period_ns() const noexcept { return period_ns_; }
  /// True between start() and stop().
  bool started() const noexcept { return started_; }
  /// When the next heartbeat is due, ns (meaningful while started and enabled).
  std::int64_t next_due_ns() const noexcept { return next_due_ns_; }
  /// Heartbeats produced since construction.
  std::uint64_t sent() const noexcept { return sent_; }
  /// Grid points skipped because poll() came more than one period late.
  std::uint64_t skipped() const noexcept { return skipped_; }

 private:
  std::uint8_t node_id_;
  bool started_ = false;
  std::int64_t period_ns_;
  std::int64_t last_sent_ns_ = 0;
  std::int64_t next_due_ns_ = 0;
  std::uint64_t sent_ = 0;
  std::uint64_t skipped_ = 0;
};

/// Condition of a node watched by a HeartbeatConsumer.
enum class HeartbeatStatus : std::uint8_t {
  kWaiting,             ///< No heartbeat yet (boot-up messages alone do not start monitoring).
  kAlive,               ///< Last heartbeat less than the timeout ago.
  kLost,                ///< Fault: no heartbeat for the timeout or longer since the last one.
  kBootedUnexpectedly,  ///< Fault: a boot-up message after the node had been heard (it reset).
};

/// Short English name of a HeartbeatStatus (static string).
const char* to_string(HeartbeatStatus status) noexcept;

/// One heartbeat fault of one node, as reported by a HeartbeatConsumer.
struct HeartbeatFault {
  /// kLost or kBootedUnexpectedly; kWaiting when no fault has happened.
  HeartbeatStatus kind = HeartbeatStatus::kWaiting;
  /// The node.
  std::uint8_t node_id = 0;
  /// Time of the last heartbeat (or boot-up message) before the fault, ns.
  std::int64_t last_heard_ns = 0;
  /// kLost: last_heard_ns + timeout, the instant the node became lost (saturated); for
  /// kBootedUnexpectedly: the boot-up message's time. ns.
  std::int64_t deadline_ns = 0;
  /// When the fault was noticed: the poll() time, or the time of the frame that revealed it
  /// (a heartbeat arriving after the deadline; a boot-up message), ns.
  std::int64_t detected_ns = 0;
};

/// Counters of a HeartbeatConsumer since construction.
struct HeartbeatConsumerCounters {
  std::uint64_t heartbeats = 0;           ///< Heartbeats (state != boot-up) accepted.
  std::uint64_t boot_ups = 0;             ///< Boot-up messages received (expected or not).
  std::uint64_t losses = 0;               ///< Transitions to kLost (faults).
  std::uint64_t unexpected_boot_ups = 0;  ///< Transitions to kBootedUnexpectedly (faults).
  std::uint64_t recoveries = 0;           ///< kLost -> kAlive (a heartbeat after a loss).
  std::uint64_t out_of_order = 0;         ///< Frames stamped before the last one heard.
  std::uint64_t wrong_length = 0;         ///< Frames on the COB-ID with length != 1.
  std::uint64_t not_data = 0;             ///< Remote / FD frames on the COB-ID.
  std::uint64_t unknown_state = 0;        ///< Frames with a state byte not in NmtState.
  /// Faults (losses + unexpected boot-ups): compare with a previous value to see every
  /// fault, even one that has already cleared (kLost -> kAlive) between two looks.
  std::uint64_t faults() const noexcept { return losses + unexpected_boot_ups; }
};

/// Heartbeat consumer for one node (CiA 301 §7.2.8.3.2.2; consumer heartbeat time, object
/// 1016h). Monitoring starts with the first heartbeat; from then on the node is kLost as soon
/// as `now - last_heard >= timeout` (exactly at last_heard + timeout, not one ns before) and
/// alive again with the next heartbeat. The outcome depends only on the frames' timestamps
/// and the timeout, not on how often poll() runs: a heartbeat stamped at or after the deadline
/// of the previous one also records the loss before it revives the node.
/// A boot-up message after the node was heard is a reset of the node: kBootedUnexpectedly,
/// and monitoring waits for the next heartbeat (which makes it kAlive again).
/// A frame stamped before the last frame heard (out of order) is counted and does not move
/// the time of the last heartbeat back nor change the reported state; a boot-up message is
/// acted on whatever its timestamp (a missed node reset is the worse error).
/// Every fault increments counters().faults() and is kept in last_fault(). Members other
/// than the constructors are noexcept and allocation free.
class HeartbeatConsumer {
 public:
  /// An unused slot (node id 0): takes no frame. For arrays; assign a configured one.
  HeartbeatConsumer() noexcept = default;
  /// Consumer of node `node_id` (1–127) with timeout `timeout_ns` (> 0; choose it above the
  /// producer period plus the bus and loop jitter, CiA 301 recommends consumer time >
  /// producer time). Throws std::invalid_argument naming the value otherwise.
  HeartbeatConsumer(std::uint8_t node_id, std::int64_t timeout_ns);

  /// Feeds one received frame. Frames not on this node's heartbeat COB-ID return kWrongId and
  /// are not counted; malformed ones on it are counted by reason and change nothing else.
  HeartbeatDecodeStatus on_frame(const CanFrame& frame) noexcept;

  /// Advances the time to `now_ns`: an alive node whose last heartbeat is `timeout` or more
  /// before `now_ns` becomes kLost (recorded once, detected at now_ns). A `now_ns` earlier
  /// than the last heartbeat counts as no time elapsed. Returns the status.
  HeartbeatStatus poll(std::int64_t now_ns) noexcept;

  /// The NMT master has reset this node (NMT reset node / reset communication, CiA 301
  /// §7.2.8.3.2.1): its next boot-up message answers the command and is not a fault. An alive
  /// or lost node returns to kWaiting (counters and the last fault are kept); monitoring
  /// resumes with the next heartbeat. Any other status is left as it is.
  void expect_boot_up() noexcept {
    if (status_ == HeartbeatStatus::kAlive || status_ == HeartbeatStatus::kLost)
      status_ = HeartbeatStatus::kWaiting;
  }

  /// The node id (0 for an unused slot).
  std::uint8_t node_id() const noexcept { return node_id_; }
  /// The consumer heartbeat time, ns.
  std::int64_t timeout_ns() const noexcept { return timeout_ns_; }
  /// Current status (as of the last on_frame() / poll()).
  HeartbeatStatus status() const noexcept { return status_; }
  /// True for kLost and kBootedUnexpectedly.
  bool faulted() const noexcept {
    return status_ == HeartbeatStatus::kLost || status_ == HeartbeatStatus::kBootedUnexpectedly;
  }
  /// True once any valid heartbeat or boot-up message has been received.
  bool heard() const noexcept { return heard_; }
  /// NMT state in the newest valid message (kBootUp before any; see heard()).
  NmtState last_state() const noexcept { return last_state_; }
  /// Timestamp of the newest valid heartbeat or boot-up message, ns (0 before any).
  std::int64_t last_heard_ns() const noexcept { return last_heard_ns_; }
  /// The latest fault (kind kWaiting if none yet).
  const HeartbeatFault& last_fault() const noexcept { return last_fault_; }
  /// Counters since construction.
  const HeartbeatConsumerCounters& counters() const noexcept { return counters_; }

 private:
  void record_loss(std::int64_t detected_ns) noexcept;

  std::uint8_t node_id_ = 0;
  std::int64_t timeout_ns_ = 0;
  HeartbeatStatus status_ = HeartbeatStatus::kWaiting;
  bool heard_ = false;
  NmtState last_state_ = NmtState::kBootUp;
  std::int64_t last_heard_ns_ = 0;
  HeartbeatFault last_fault_;
  HeartbeatConsumerCounters counters_;
};

/// Default capacity of a HeartbeatMonitor (nodes).
inline constexpr std::size_t kDefaultHeartbeatMonitorCapacity = 16;

/// Heartbeat consumers for up to `N` nodes in a fixed array, frames routed by COB-ID through
/// a 128-entry node table (O(1) per frame). add() is setup (may throw); on_frame(), poll()
/// and the queries are noexcept and allocation free.
template <std::size_t N = kDefaultHeartbeatMonitorCapacity>
class HeartbeatMonitor {
  static_assert(N >= 1 && N <= kMaxNodeId, "HeartbeatMonitor capacity must be 1-127");

 public:
  /// An empty monitor.
  HeartbeatMonitor() noexcept { slot_of_node_.fill(kNoSlot); }

  /// Watches node `node_id` with timeout `timeout_ns` (HeartbeatConsumer rules). Throws
  /// std::invalid_argument if the node is already watched or the values are out of range,
  /// std::length_error if N nodes are already watched.
  void add(std::uint8_t node_id, std::int64_t timeout_ns) {
    HeartbeatConsumer consumer(node_id, timeout_ns);  // validates
    if (slot_of_node_[node_id] != kNoSlot) {
      throw std::invalid_argument("HeartbeatMonitor::add: node id " + std::to_string(node_id) +
                                  " is already watched");
    }
    if (size_ == N) {
      throw std::length_error("HeartbeatMonitor::add: capacity of " + std::to_string(N) +
                              " nodes reached (node id " + std::to_string(node_id) + ")");
    }
    consumers_[size_] = consumer;
    slot_of_node_[node_id] = static_cast<std::uint8_t>(size_);
    ++size_;
  }

  /// Routes `frame` to the consumer of its node. Returns kWrongId (and counts it in
  /// unrouted()) if the frame is not on the heartbeat COB-ID of a watched node; otherwise the
  /// consumer's result.
  HeartbeatDecodeStatus on_frame(const CanFrame& frame) noexcept {
    if (is_standard_frame(frame) && frame.id > kHeartbeatBaseCobId &&
        frame.id <= kHeartbeatBaseCobId + kMaxNodeId) {
      const std::uint8_t slot = slot_of_node_[frame.id - kHeartbeatBaseCobId];
      if (slot != kNoSlot) return consumers_[slot].on_frame(frame);
    }
    ++unrouted_;
    return HeartbeatDecodeStatus::kWrongId;
  }

  /// Polls every consumer with `now_ns`.
  void poll(std::int64_t now_ns) noexcept {
    for (std::size_t i = 0; i < size_; ++i) consumers_[i].poll(now_ns);
  }

  /// The consumer of `node_id`, or nullptr if that node is not watched.
  const HeartbeatConsumer* find(std::uint8_t node_id) const noexcept {
    if (node_id > kMaxNodeId || slot_of_node_[node_id] == kNoSlot) return nullptr;
    return &consumers_[slot_of_node_[node_id]];
  }
  /// HeartbeatConsumer::expect_boot_up() of node `node_id`; no effect for a node not watched.
  void expect_boot_up(std::uint8_t node_id) noexcept {
    if (node_id <= kMaxNodeId && slot_of_node_[node_id] != kNoSlot)
      consumers_[slot_of_node_[node_id]].expect_boot_up();
  }

  /// The consumers, in add() order.
  std::span<const HeartbeatConsumer> consumers() const noexcept {
    return std::span<const HeartbeatConsumer>(consumers_.data(), size_);
  }
  /// Number of watched nodes.
  std::size_t size() const noexcept { return size_; }
  /// Capacity N.
  static constexpr std::size_t capacity() noexcept { return N; }

  /// True if there is at least one node and every node is kAlive.
  bool all_alive() const noexcept {
    if (size_ == 0) return false;
    for (std::size_t i = 0; i < size_; ++i) {
      if (consumers_[i].status() != HeartbeatStatus::kAlive) return false;
    }
    return true;
  }
  /// True if any node is kLost or kBootedUnexpectedly now.
  bool any_fault() const noexcept {
    for (std::size_t i = 0; i < size_; ++i) {
      if (consumers_[i].faulted()) return true;
    }
    return false;
  }
  /// Sum of the consumers' fault counts: increases with every fault, including ones that
  /// have already cleared. The controller compares it with the value it last acted on.
  std::uint64_t fault_count() const noexcept {
    std::uint64_t n = 0;
    for (std::size_t i = 0; i < size_; ++i) n += consumers_[i].counters().faults();
    return n;
  }
  /// Frames given to on_frame() that were not a watched node's heartbeat COB-ID.
  std::uint64_t unrouted() const noexcept { return unrouted_; }

 private:
  static constexpr std::uint8_t kNoSlot = 0xFF;
  std::array<HeartbeatConsumer, N> consumers_{};
  std::array<std::uint8_t, kMaxNodeId + 1> slot_of_node_{};
  std::size_t size_ = 0;
  std::uint64_t unrouted_ = 0;
};

}  // namespace numen::hal
