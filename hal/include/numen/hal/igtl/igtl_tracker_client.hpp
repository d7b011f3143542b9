#pragma once
/// @file igtl_tracker_client.hpp
/// IgtlTrackerClient: the receiver thread of the OpenIGTLink tracker bus (igtl_tracker_bus.hpp).
/// It connects to an OpenIGTLink server (a PLUS server, a tracker's bridge, `numen igtl-replay`)
/// over TCP, reads its messages, decodes and checks them (igtl_message.hpp) and pushes the
/// poses (TRANSFORM, POSITION or QTRANS messages, mixed as the server likes) of the tracked
/// tools — one device name each, e.g. "StylusToTracker"; several tools share one connection,
/// as PLUS sends them — into a bounded single-producer / single-consumer lock-free queue per
/// tool (boost::lockfree::spsc_queue, its capacity fixed at construction) that the control
/// period drains without blocking, locking or allocating. The network is read here, never in
/// the period.
///
/// Bad input is counted and located, never fatal: a message whose header is not OpenIGTLink
/// (version, type name) or whose body size is above the limit loses the stream's framing, so the
/// connection is closed and made again; a pose message with a CRC mismatch, a body size that is
/// not its type's, a NaN, a rotation that is not orthonormal or a quaternion that is not of unit
/// length is skipped; a type that OpenIGTLink v2 does not have is skipped (its body read and
/// discarded through a fixed buffer: memory never grows with what the server sends); the poses
/// of other device names are counted and their names kept (at most kIgtlMaxNamesSeen). A full
/// queue (a flood, or a consumer that stopped) drops the newest pose and counts it, unless
/// `wait_when_full` (an offline run that follows the tracker's clock: the receiver then waits,
/// and TCP's flow control slows the server).
/// Construction allocates and may throw; the thread's work allocates (the library's message
/// objects are made once); the consumer side (pop(), front(), counters()) is noexcept, lock free
/// and allocation free.

#include <array>
#include <atomic>
#include <cstddef>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <boost/lockfree/spsc_queue.hpp>

#include "numen/core/types.hpp"
#include "numen/hal/igtl/igtl_message.hpp"

namespace numen::hal {

/// Default OpenIGTLink port (PLUS server and Slicer's OpenIGTLinkIF).
inline constexpr std::uint16_t kIgtlDefaultPort = 18944;
/// Other device names an IgtlTrackerClient keeps (to say which names a server does send).
inline constexpr std::size_t kIgtlMaxNamesSeen = 8;
/// Tools one IgtlTrackerClient reads (device_name and more_device_names).
inline constexpr std::size_t kIgtlMaxTools = 4;

/// Creation settings of an IgtlTrackerClient.
struct IgtlTrackerClientSettings {
  std::string host = "127.0.0.1";        ///< Server: an IPv4 address or a host name.
  std::uint16_t port = kIgtlDefaultPort; ///< Server's TCP port, > 0.
  std::string device_name;               ///< The tool's device name, 1..20 characters (tool 0).
  /// Other tools on the same connection, tools 1, 2, ... (each 1..20 characters, all names
  /// distinct; at most kIgtlMaxTools − 1), each into its own queue of queue_poses.
  std::vector<std::string> more_device_names;
  std::size_t queue_poses = 1024;        ///< Capacity of each tool's pose queue, >= 1.
  /// Full queue: true, the receiver waits for room (offline runs); false, the newest pose is
  /// dropped and counted (IgtlClientCounters::dropped_full).
  bool wait_when_full = false;
  /// Connect again after a refused or lost connection (every reconnect_interval_ns); false: the
  /// client ends (ended()) at the first refusal or loss.
  bool reconnect = true;
  std::int64_t connect_timeout_ns = 1'000'000'000;    ///< One connect attempt's limit, > 0.
  std::int64_t reconnect_interval_ns = 200'000'000;   ///< Between attempts, > 0.
  std::size_t max_body_bytes = std::size_t{1} << 24;  ///< Larger bodies lose the framing.
  double rigid_tolerance = kIgtlRigidTolerance;       ///< IgtlDecoder::decode_transform().
  /// The device name of a TRANSFORM kept as the registration (registration(): the newest one
  /// received); empty: none. Not the tool's name.
  std::string registration_name;
};

/// One accepted pose message (TRANSFORM, POSITION or QTRANS) of the tool.
struct IgtlPose {
  /// The message's timestamp, ns since the sender's epoch (0: the sender set none).
  std::int64_t stamp_ns = 0;
  /// When the receiver had the whole message, CLOCK_MONOTONIC ns.
  std::int64_t received_mono_ns = 0;
  core::Mat3 rotation = core::Mat3::Identity();  ///< Orthonormal, det +1.
  core::Vec3 translation = core::Vec3::Zero();   ///< In the sender's units.
};

/// Counters of an IgtlTrackerClient since construction (a snapshot of atomics).
struct IgtlClientCounters {
  std::uint64_t messages = 0;           ///< Headers read.
  std::uint64_t bytes = 0;              ///< Bytes read.
  std::uint64_t poses = 0;              ///< The tools' poses accepted (queued or dropped).
  std::array<std::uint64_t, kIgtlMaxTools> tool_poses{};  ///< ... per tool.
  std::uint64_t other_devices = 0;      ///< Good poses of other device names.
  std::uint64_t ignored = 0;            ///< Other known message types (skipped).
  std::array<std::uint64_t, kIgtlFaultCount> faults{};  ///< Per IgtlFault (index 0 unused).
  std::uint64_t dropped_full = 0;       ///< Poses dropped: the queue was full.
  std::uint64_t connects = 0;           ///< Connections made.
  std::uint64_t connect_failures = 0;   ///< Connect attempts refused or timed out.
  std::uint64_t disconnects = 0;        ///< Connections lost (server closed, reset, bad framing).
  /// Total of faults[].
  std::uint64_t faults_total() const noexcept {
    std::uint64_t n = 0;
    for (std::uint64_t f : faults) n += f;
    return n;
  }
};

/// Where a fault was first seen.
struct IgtlFaultRecord {
  IgtlFault fault = IgtlFault::kNone;
  std::string type;          ///< The message's type name (may be garbage for kBadHeader).
  std::string device_name;   ///< The message's device name.
  std::uint64_t message = 0; ///< Index of the message on its connection (0-based).
  std::uint64_t stream_offset = 0;  ///< Byte offset of the message's start on its connection.
  std::size_t byte_offset = 0;      ///< Offset of the failing field in the message.
};

/// "CRC mismatch: TRANSFORM 'StylusToTracker', message 12 at stream byte 1272, field at byte 50"
std::string describe(const IgtlFaultRecord& record);

/// The receiver (see the file comment). Not copyable; one consumer thread.
class IgtlTrackerClient {
 public:
  /// Checks `settings` (std::invalid_argument naming the field: an empty or too long device name,
  /// two tools of one name, more than kIgtlMaxTools tools, a registration named as a tool,
  /// port 0, queue_poses 0, non-positive times) and starts the thread, which connects at once.
  explicit IgtlTrackerClient(IgtlTrackerClientSettings settings);
  /// Stops the thread (within ~50 ms) and closes the connection.
  ~IgtlTrackerClient();
  IgtlTrackerClient(const IgtlTrackerClient&) = delete;
  IgtlTrackerClient& operator=(const IgtlTrackerClient&) = delete;

  // ---- consumer side: noexcept, lock free, allocation free ----
  /// The oldest queued pose of tool `tool` (0: device_name, k: more_device_names[k − 1]; one
  /// consumer thread per tool), or nullptr if none (or no such tool). Valid until pop(tool).
  const IgtlPose* front(std::size_t tool = 0) noexcept;
  /// Removes the oldest queued pose of `tool` (precondition: front(tool) != nullptr).
  void pop(std::size_t tool = 0) noexcept;
  /// Tools read: 1 + more_device_names.size().
  std::size_t tool_count() const noexcept { return queues_.size(); }
  /// The stamp of the first stamped pose accepted on this client (stamp not 0), of any tool
  /// (IgtlPose::stamp_ns); false before one. Set before that pose is queued: a consumer that has a
  /// pose sees it.
  bool first_stamp_ns(std::int64_t& out) const noexcept {
    if (!has_first_stamp_.load(std::memory_order_acquire)) return false;
    out = first_stamp_ns_;
    return true;
  }
  /// Connected to the server now.
  bool connected() const noexcept { return connected_.load(std::memory_order_acquire); }
  /// The thread has ended: stop requested, or (reconnect off) the connection refused or lost.
  /// Every pose it queued is still in the queue.
  bool ended() const noexcept { return ended_.load(std::memory_order_acquire); }
  /// Counters now.
  IgtlClientCounters counters() const noexcept;

  // ---- not real-time ----
  /// The first record of each fault kind seen (allocates; locks a mutex the period never takes).
  std::vector<IgtlFaultRecord> fault_records() const;
  /// Device names of the other poses (at most kIgtlMaxNamesSeen; the registration's is not
  /// one).
  std::vector<std::string> names_seen() const;
  /// The newest pose named settings().registration_name (a TRANSFORM, POSITION or QTRANS,
  /// checked as the tool's), or none yet (locks the mutex the period never takes).
  std::optional<IgtlTransform> registration() const;
  /// The newest pose message named settings().registration_name that was refused (its fault:
  /// a NaN, a rotation that is not rigid, a CRC mismatch, ...), or none (locks the mutex the
  /// period never takes). A registration that arrived and was refused is said as such, not as
  /// one that never came.
  std::optional<IgtlFaultRecord> registration_refused() const;
  /// The settings.
  const IgtlTrackerClientSettings& settings() const noexcept { return settings_; }
  /// Stops the thread and waits for it (idempotent).
  void stop();

 private:
  enum class ReadResult : std::uint8_t { kOk, kClosed, kStopped };
  void run();
  int connect_once();
  ReadResult read_fully(int fd, std::uint8_t* out, std::size_t n);
  // One connection's messages until it is lost or stopped.
  void session(int fd);
  void fault(IgtlFault f, const IgtlHeader& h, std::uint64_t message, std::uint64_t at,
             std::size_t offset);
  void push(const IgtlPose& pose, std::size_t tool);
  // The tool of device name `name`, or tool_count() if none.
  std::size_t tool_of(const std::string& name) const noexcept;
  void count(std::atomic<std::uint64_t>& c, std::uint64_t n = 1) noexcept {
    c.fetch_add(n, std::memory_order_relaxed);
  }

  IgtlTrackerClientSettings settings_;
  std::vector<std::unique_ptr<boost::lockfree::spsc_queue<IgtlPose>>> queues_;  // per tool
  std::int64_t first_stamp_ns_ = 0;  // written once, before has_first_stamp_ (release)
  std::atomic<bool> has_first_stamp_{false};
  std::atomic<bool> stop_{false};
  std::atomic<bool> connected_{false};
  std::atomic<bool> ended_{false};
  std::atomic<std::uint64_t> messages_{0}, bytes_{0}, poses_{0}, other_devices_{0}, ignored_{0},
      dropped_full_{0}, connects_{0}, connect_failures_{0}, disconnects_{0};
  std::array<std::atomic<std::uint64_t>, kIgtlFaultCount> faults_{};
  std::array<std::atomic<std::uint64_t>, kIgtlMaxTools> tool_poses_{};
  mutable std::mutex records_mutex_;  // records_ and names_: the thread and the summary only
  std::vector<IgtlFaultRecord> records_;
  std::vector<std::string> names_;
  std::optional<IgtlTransform> registration_;  // under records_mutex_
  std::optional<IgtlFaultRecord> registration_refused_;  // under records_mutex_
  std::thread thread_;
};

}  // namespace numen::hal
