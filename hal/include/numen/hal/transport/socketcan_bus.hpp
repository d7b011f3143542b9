#pragma once
/// @file socketcan_bus.hpp
/// SocketCanBus: a numen::hal::Bus on a Linux SocketCAN raw socket (PF_CAN, SOCK_RAW, CAN_RAW;
/// Linux Documentation/networking/can.rst, "How to use SocketCAN"). Classic CAN and CAN FD
/// (CAN_RAW_FD_FRAMES), kernel acceptance filters (CAN_RAW_FILTER), controller error frames
/// (CAN_RAW_ERR_FILTER, linux/can/error.h) mapped to BusState, kernel receive timestamps
/// (SO_TIMESTAMPNS) and the socket's drop counter (SO_RXQ_OVFL).
///
/// Real-time contract: read(), write(), state(), counters(), link_down() never allocate, throw,
/// lock or block (O_NONBLOCK socket, MSG_DONTWAIT, a preallocated iovec and ancillary buffer).
/// Setup calls (open(), adopt(), set_filters(), reopen(), close()) may allocate and throw.
/// wait_readable() and refresh_link() are for non-real-time callers.
///
/// The pure conversions (encode_socketcan(), decode_socketcan(), to_kernel_filter(),
/// decode_error_frame()) are free functions so they can be tested without a CAN-capable
/// kernel. See docs/transports.md, "SocketCAN transport".

#include <linux/can.h>

#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// Every error class of linux/can/error.h (CAN_ERR_MASK): the default error-frame subscription.
inline constexpr std::uint32_t kAllCanErrorClasses = CAN_ERR_MASK;

/// Settings of a SocketCanBus, applied by open(). Checked by open() (std::invalid_argument).
struct SocketCanOptions {
  /// Enable CAN FD (CAN_RAW_FD_FRAMES): FD frames can be written (the interface needs MTU 72,
  /// `ip link set can0 mtu 72`) and are read as FD. Classic frames pass either way.
  bool fd_frames = true;
  /// Error classes to receive as error frames (CAN_RAW_ERR_FILTER; bits CAN_ERR_* of
  /// linux/can/error.h, e.g. CAN_ERR_CRTL | CAN_ERR_BUSOFF | CAN_ERR_RESTARTED). 0: none, and
  /// state() then stays kOk unless the link goes down. Default: all classes.
  std::uint32_t error_classes = kAllCanErrorClasses;
  /// CAN_RAW_LOOPBACK: frames written here are also delivered to the other sockets of this
  /// host on the same interface (kernel default: on). Needed on vcan, where every peer is local.
  bool loopback = true;
  /// CAN_RAW_RECV_OWN_MSGS: this socket also reads the frames it wrote (kernel default: off).
  bool receive_own_messages = false;
  /// SO_RCVBUF in bytes; 0 keeps the kernel default (net.core.rmem_default). The kernel
  /// doubles the value and accounts the whole skb (~ 0.5–1 KiB per CAN frame), so a small
  /// value holds few frames; overflow is counted in BusCounters::dropped.
  int receive_buffer_bytes = 0;
  /// send() attempts per write() on ENOBUFS / EAGAIN (transmit queue or socket buffer full),
  /// >= 1, immediately one after another (no sleep); after the last one write() returns
  /// kWouldBlock. Each extra attempt is counted in SocketCanCounters::tx_retries.
  int write_attempts = 3;
  /// Allow write() of frames flagged CanFlag::kErrorFrame (sent as CAN_ERR_FLAG frames). Only
  /// for fault injection on vcan: on real hardware the driver would put their id on the wire.
  bool allow_error_frame_write = false;
};

/// Event counters of a SocketCanBus beyond BusCounters, since construction (kept by reopen()).
struct SocketCanCounters {
  std::uint64_t error_frames = 0;  ///< Error frames read (also counted in frames_rx).
  std::uint64_t bus_off = 0;       ///< Error frames with CAN_ERR_BUSOFF.
  std::uint64_t restarts = 0;      ///< Error frames with CAN_ERR_RESTARTED (controller restart
                                   ///< after bus off, `ip link set can0 type can restart-ms`).
  std::uint64_t controller_overflows = 0;  ///< CAN_ERR_CRTL_RX/TX_OVERFLOW reports: frames lost
                                           ///< in the controller (count unknown; not in dropped).
  std::uint64_t tx_retries = 0;            ///< Extra send() attempts after ENOBUFS / EAGAIN.
  std::uint64_t malformed_rx = 0;  ///< Datagrams rejected by read(): size neither CAN_MTU nor
                                   ///< CANFD_MTU, truncated, or failing check_frame().
  std::uint64_t link_down = 0;     ///< Transitions into link_down() (ENETDOWN, ENODEV, ENXIO).
  std::uint64_t reopens = 0;       ///< Successful reopen() calls.
  std::uint64_t no_kernel_timestamp = 0;  ///< Frames without SO_TIMESTAMPNS data (timestamped
                                          ///< with CLOCK_MONOTONIC at read time instead).
  int last_errno = 0;                     ///< errno of the last failed socket call (0: none yet).
};

/// What one SocketCAN error frame says about the controller (linux/can/error.h).
struct CanErrorReport {
  /// The frame sets the fault confinement state: CAN_ERR_BUSOFF, CAN_ERR_RESTARTED, or
  /// CAN_ERR_CRTL with a warning / passive / active bit in data[1].
  bool has_state = false;
  /// The new state when has_state: kBusOff (CAN_ERR_BUSOFF) over kErrorPassive
  /// (CAN_ERR_CRTL_RX/TX_PASSIVE) over kErrorWarning (CAN_ERR_CRTL_RX/TX_WARNING) over kOk
  /// (CAN_ERR_CRTL_ACTIVE or CAN_ERR_RESTARTED: a restarted controller is error active).
  BusState state = BusState::kOk;
  bool bus_off = false;               ///< CAN_ERR_BUSOFF.
  bool restarted = false;             ///< CAN_ERR_RESTARTED.
  bool controller_overflow = false;   ///< CAN_ERR_CRTL with CAN_ERR_CRTL_RX/TX_OVERFLOW.
  bool has_error_counters = false;    ///< CAN_ERR_CNT: tx/rx error counters in data[6]/data[7].
  std::uint8_t tx_error_counter = 0;  ///< Transmit error counter (data[6]) when has_error_counters.
  std::uint8_t rx_error_counter = 0;  ///< Receive error counter (data[7]) when has_error_counters.
};

/// Decodes an error frame (CanFlag::kErrorFrame; id = CAN_ERR_* class bits, data as in
/// linux/can/error.h: data[1] controller status). A frame without kErrorFrame gives an empty
/// report. Never allocates.
CanErrorReport decode_error_frame(const CanFrame& frame) noexcept;

/// Writes `frame` into `out` as SocketCAN sends it: can_id = id | CAN_EFF_FLAG / CAN_RTR_FLAG /
/// CAN_ERR_FLAG, len, flags = CANFD_BRS / CANFD_ESI for FD frames (CANFD_FDF is left to the
/// kernel: Linux >= 6.2 sets it, older kernels do not define it); payload bytes
/// >= len zeroed. Returns the byte count to send: CANFD_MTU (72) for FD frames, CAN_MTU (16,
/// a `struct can_frame`, which is the head of `struct canfd_frame`) otherwise; 0 (and `out`
/// unspecified) if check_frame(frame) != kNone.
std::size_t encode_socketcan(const CanFrame& frame, canfd_frame& out) noexcept;

/// Reads a received `struct canfd_frame` of `nbytes` bytes into `frame`: CAN_MTU -> classic
/// (EFF / RTR / ERR flags from can_id), CANFD_MTU -> FD (kFd, BRS, ESI). `timestamp_ns` is left
/// unchanged. Returns false (`frame` unspecified) for any other size or a frame that fails
/// check_frame() (e.g. an FD length 13, a classic length > 8, an FD remote request).
bool decode_socketcan(const canfd_frame& in, std::size_t nbytes, CanFrame& frame) noexcept;

/// The kernel filter of `filter` (their bit layouts match, can_filter.hpp). Bit 29 is cleared in
/// both words: in can_id it would mean CAN_INV_FILTER, in can_mask CAN_ERR_FLAG would turn the
/// entry into an error-frame filter (net/can/af_can.c); neither is part of CanFilter.
can_filter to_kernel_filter(const CanFilter& filter) noexcept;

/// Maps a SO_TIMESTAMPNS receive time (CLOCK_REALTIME, ns) to CLOCK_MONOTONIC, given the two
/// clocks read together now (read() takes CLOCK_REALTIME on both sides of CLOCK_MONOTONIC and
/// uses the midpoint): mono = realtime_ns + (mono_now_ns - realtime_now_ns), capped at
/// mono_now_ns (a frame cannot have been received after it was read; guards a wall-clock step
/// between reception and read). A wall-clock step between those two instants shifts the result
/// by the step (at most back to the cap).
std::int64_t realtime_to_monotonic_ns(std::int64_t realtime_ns, std::int64_t realtime_now_ns,
                                      std::int64_t mono_now_ns) noexcept;

/// A Bus on one SocketCAN interface. Not thread safe: one owner (the control loop); the setup
/// calls must not run concurrently with read()/write(). Not copyable or movable (owns the fd).
///
/// State: state() is kBusOff while link_down() (interface down or gone), else the controller
/// state from the last error frame that carried one (decode_error_frame()). While the
/// controller is bus off, write() refuses frames with kError (they would go out stale after
/// the restart); read() keeps reading, which is how the CAN_ERR_RESTARTED frame is seen.
class SocketCanBus final : public Bus {
 public:
  /// A closed port: read()/write() return kError until open() or adopt().
  SocketCanBus() noexcept;
  /// Same as open(interface_name, filters, options).
  SocketCanBus(std::string_view interface_name, std::span<const CanFilter> filters = {},
               const SocketCanOptions& options = {});
  ~SocketCanBus() override;
  SocketCanBus(const SocketCanBus&) = delete;
  SocketCanBus& operator=(const SocketCanBus&) = delete;
  SocketCanBus(SocketCanBus&&) = delete;
  SocketCanBus& operator=(SocketCanBus&&) = delete;

  /// Opens a CAN_RAW socket bound to `interface_name` (e.g. "can0", "vcan0"), non-blocking,
  /// with the kernel filters `filters` (empty: every frame; at most CAN_RAW_FILTER_MAX = 512),
  /// the options, SO_TIMESTAMPNS and SO_RXQ_OVFL. Closes a previous socket first. Setup only.
  /// Throws std::invalid_argument for bad options (naming the field) or too many filters;
  /// std::runtime_error naming the interface and the failing call with strerror(errno), e.g.
  /// "SocketCAN interface 'can9' does not exist" or "... socket(PF_CAN, SOCK_RAW, CAN_RAW):
  /// Address family not supported by protocol" on a kernel without CAN.
  void open(std::string_view interface_name, std::span<const CanFilter> filters = {},
            const SocketCanOptions& options = {});

  /// Takes ownership of an already configured datagram socket `fd` (e.g. received over
  /// SCM_RIGHTS from a privileged helper, or one end of a socketpair in tests), named
  /// `name` in messages. Sets O_NONBLOCK, SO_TIMESTAMPNS and SO_RXQ_OVFL; sets no CAN option
  /// (the owner did). reopen() is not possible. Throws std::invalid_argument if fd < 0 or the
  /// options are bad; std::runtime_error naming the call if fcntl/setsockopt fails (fd is
  /// then closed).
  void adopt(int fd, std::string_view name, const SocketCanOptions& options = {});

  /// Replaces the kernel filters (CAN_RAW_FILTER; empty: every frame). Setup / non-real-time.
  /// Throws like open().
  void set_filters(std::span<const CanFilter> filters);

  /// Closes the socket and opens it again with the same interface name, filters and options:
  /// for an interface that was deleted and created again (ENODEV / ENXIO: the kernel unbinds
  /// the socket, needs_reopen() is true). Not needed after `ip link set dev down` / `up`: the
  /// socket stays bound and works again. Counters and controller state are kept (the drop
  /// baseline restarts with the new socket); link_down() is cleared. Non-real-time (allocates,
  /// throws like open(); on failure the port is left closed and link_down()).
  void reopen();

  /// Closes the socket (idempotent). read()/write() return kError afterwards.
  void close() noexcept;

  /// Takes the oldest received frame. Data frames pass the kernel filters; error frames
  /// (controller reports) are returned too, with CanFlag::kErrorFrame, after updating state()
  /// (the loop logs them; the device layer ignores them). timestamp_ns: kernel receive time
  /// mapped to CLOCK_MONOTONIC (realtime_to_monotonic_ns()), or CLOCK_MONOTONIC at read time
  /// if the kernel gave none. Datagrams that are not a valid frame are skipped and counted in
  /// malformed_rx (at most 16 per call, then kWouldBlock). SO_RXQ_OVFL increments go into
  /// BusCounters::dropped. kWouldBlock: nothing pending. kError: socket closed, link down
  /// (ENETDOWN once, then every call until a frame received after the failure or a successful
  /// write() shows the link up again), or another recvmsg() failure (last_errno).
  IoStatus read(CanFrame& frame) noexcept override;

  /// Sends `frame` (MSG_DONTWAIT). kOk: queued. kWouldBlock: ENOBUFS / EAGAIN on all
  /// write_attempts attempts (not sent; tx_would_block). kError: closed, malformed
  /// (check_frame()), an FD frame with fd_frames off, an error frame without
  /// allow_error_frame_write, controller bus off, link down (ENETDOWN; ENODEV / ENXIO also set
  /// needs_reopen()), or another send() failure (last_errno, e.g. EINVAL for an FD frame on an
  /// interface with MTU 16). A write that succeeds clears link_down().
  IoStatus write(const CanFrame& frame) noexcept override;

  /// kBusOff while link_down(); otherwise the controller state from the error frames read.
  BusState state() const noexcept override { return link_down_ ? BusState::kBusOff : state_; }
  /// Counters of this port (dropped: SO_RXQ_OVFL increments).
  BusCounters counters() const noexcept override { return counters_; }

  /// The controller state from error frames alone (ignores link_down()).
  BusState controller_state() const noexcept { return state_; }
  /// True after ENETDOWN / ENODEV / ENXIO until the link is seen working again (see read(),
  /// write(), refresh_link(), reopen()). "Interface down" rather than a controller bus off.
  bool link_down() const noexcept { return link_down_; }
  /// True after ENODEV / ENXIO: the interface was removed and the socket unbound; only
  /// reopen() recovers.
  bool needs_reopen() const noexcept { return needs_reopen_; }
  /// SocketCAN-specific counters.
  const SocketCanCounters& socketcan_counters() const noexcept { return extra_; }
  /// True while a socket is open.
  bool is_open() const noexcept { return fd_ >= 0; }
  /// The socket (for epoll in a non-real-time supervisor); -1 when closed.
  int native_handle() const noexcept { return fd_; }
  /// Interface (or adopted socket) name given at open()/adopt().
  const std::string& name() const noexcept { return name_; }

  /// Waits up to `timeout_ns` (>= 0; 0 polls) for a frame, an error or a hang-up on the
  /// socket (ppoll). True if read() has something to report, false on timeout, on EINTR or
  /// when closed. Blocks: non-real-time callers only (supervisors, tests, tools).
  bool wait_readable(std::int64_t timeout_ns) const noexcept;

  /// Asks the kernel whether the interface is up (ioctl SIOCGIFFLAGS, IFF_UP) and the socket
  /// still bound (getsockname: can_ifindex != 0); clears link_down() when both hold and
  /// !needs_reopen(). Sets link_down() if the interface is down, and also needs_reopen() if it
  /// is gone or the socket was unbound. When up, a stale socket error left from the down time
  /// is cleared (SO_ERROR). Returns !link_down(). Adopted sockets: no check.
  /// Non-real-time (an ioctl on the device list).
  bool refresh_link() noexcept;

 private:
  void configure(int fd, std::span<const CanFilter> filters);
  void apply_filters(int fd, std::span<const CanFilter> filters) const;
  void enable_common(int fd);
  void mark_link_down(int err, bool gone) noexcept;

  int fd_ = -1;
  bool adopted_ = false;
  std::string name_;
  SocketCanOptions options_{};
  std::vector<CanFilter> filters_;
  BusState state_ = BusState::kOk;
  bool link_down_ = false;
  bool needs_reopen_ = false;
  std::int64_t link_down_since_ns_ = 0;  // CLOCK_MONOTONIC when link_down_ was set
  std::uint32_t last_drop_count_ = 0;    // last SO_RXQ_OVFL value of this socket
  BusCounters counters_{};
  SocketCanCounters extra_{};
  // Preallocated receive buffers: one frame and the ancillary data (timestamp + drop count).
  canfd_frame rx_frame_{};
  alignas(8) unsigned char control_[64]{};
};

}  // namespace numen::hal
