/// @file socketcan_bus.cpp
/// Bus on a Linux SocketCAN raw socket (Documentation/networking/can.rst): conversions to and
/// from struct canfd_frame, error-frame decoding (linux/can/error.h), the non-blocking
/// recvmsg/send paths and the setup calls.

#include "numen/hal/transport/socketcan_bus.hpp"

#include <fcntl.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <limits>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

static_assert(alignof(cmsghdr) <= 8, "control buffer alignment");
static_assert(CMSG_SPACE(sizeof(timespec)) + CMSG_SPACE(sizeof(std::uint32_t)) <= 64,
              "control buffer holds SCM_TIMESTAMPNS and SO_RXQ_OVFL");
static_assert(sizeof(can_frame) == CAN_MTU && sizeof(canfd_frame) == CANFD_MTU);
// CanFilter's bits are SocketCAN's (can_filter.hpp).
static_assert(kFilterExtendedBit == CAN_EFF_FLAG && kFilterRemoteBit == CAN_RTR_FLAG);

constexpr int kMaxSkippedPerRead = 16;

std::int64_t clock_ns(clockid_t id) noexcept {
  timespec ts{};
  clock_gettime(id, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::string errno_text(int err) { return std::strerror(err); }

[[noreturn]] void fail(const std::string& name, const char* call, int err) {
  throw std::runtime_error("SocketCAN interface '" + name + "': " + call + ": " + errno_text(err));
}

void check_options(const SocketCanOptions& o) {
  if (o.write_attempts < 1) {
    throw std::invalid_argument("SocketCanOptions.write_attempts must be >= 1 (got " +
                                std::to_string(o.write_attempts) + ")");
  }
  if (o.receive_buffer_bytes < 0) {
    throw std::invalid_argument("SocketCanOptions.receive_buffer_bytes must be >= 0 (got " +
                                std::to_string(o.receive_buffer_bytes) + ")");
  }
  if ((o.error_classes & ~CAN_ERR_MASK) != 0) {
    throw std::invalid_argument(
        "SocketCanOptions.error_classes has bits outside CAN_ERR_MASK (0x1FFFFFFF)");
  }
}

void check_filters(std::span<const CanFilter> filters) {
  if (filters.size() > CAN_RAW_FILTER_MAX) {
    throw std::invalid_argument(
        "SocketCAN: " + std::to_string(filters.size()) +
        " filters, at most CAN_RAW_FILTER_MAX = " + std::to_string(CAN_RAW_FILTER_MAX));
  }
}

void set_int_option(int fd, int level, int option, int value, const std::string& name,
                    const char* what) {
  if (setsockopt(fd, level, option, &value, sizeof(value)) != 0) fail(name, what, errno);
}

}  // namespace

// ---------------------------------------------------------------------------------------------
// Pure conversions

CanErrorReport decode_error_frame(const CanFrame& frame) noexcept {
  CanErrorReport r;
  if (!frame.error_frame()) return r;
  const std::uint32_t cls = frame.id;
  const std::uint8_t ctrl = frame.len > 1 ? frame.data[1] : 0;
  if ((cls & CAN_ERR_RESTARTED) != 0) {
    r.restarted = true;
    r.has_state = true;
    r.state = BusState::kOk;
  }
  if ((cls & CAN_ERR_CRTL) != 0) {
    if ((ctrl & (CAN_ERR_CRTL_RX_OVERFLOW | CAN_ERR_CRTL_TX_OVERFLOW)) != 0) {
      r.controller_overflow = true;
    }
    // The kernel (drivers/net/can/dev: can_change_state) sets the bits of the new state.
    if ((ctrl & (CAN_ERR_CRTL_RX_PASSIVE | CAN_ERR_CRTL_TX_PASSIVE)) != 0) {
      r.has_state = true;
      r.state = BusState::kErrorPassive;
    } else if ((ctrl & (CAN_ERR_CRTL_RX_WARNING | CAN_ERR_CRTL_TX_WARNING)) != 0) {
      r.has_state = true;
      r.state = BusState::kErrorWarning;
    } else if ((ctrl & CAN_ERR_CRTL_ACTIVE) != 0) {
      r.has_state = true;
      r.state = BusState::kOk;
    }
  }
  if ((cls & CAN_ERR_BUSOFF) != 0) {
    r.bus_off = true;
    r.has_state = true;
    r.state = BusState::kBusOff;
  }
  if ((cls & CAN_ERR_CNT) != 0 && frame.len >= 8) {
    r.has_error_counters = true;
    r.tx_error_counter = frame.data[6];
    r.rx_error_counter = frame.data[7];
  }
  return r;
}

std::size_t encode_socketcan(const CanFrame& frame, canfd_frame& out) noexcept {
  if (check_frame(frame) != FrameError::kNone) return 0;
  std::memset(&out, 0, sizeof(out));
  if (frame.error_frame()) {
    out.can_id = CAN_ERR_FLAG | (frame.id & CAN_ERR_MASK);
  } else if (frame.extended()) {
    out.can_id = CAN_EFF_FLAG | (frame.id & CAN_EFF_MASK);
  } else {
    out.can_id = frame.id & CAN_SFF_MASK;
  }
  if (frame.remote()) out.can_id |= CAN_RTR_FLAG;
  out.len = frame.len;
  // A remote request carries no data (len is the requested length).
  if (!frame.remote()) std::memcpy(out.data, frame.data.data(), frame.len);
  if (frame.fd()) {
    // The byte count (CANFD_MTU) marks an FD frame; CANFD_FDF (Linux >= 6.2) is set by the
    // kernel itself and undefined before, so it is not sent.
    if ((frame.flags & CanFlag::kBitRateSwitch) != 0) out.flags |= CANFD_BRS;
    if ((frame.flags & CanFlag::kErrorStateIndicator) != 0) out.flags |= CANFD_ESI;
    return CANFD_MTU;
  }
  return CAN_MTU;
}

bool decode_socketcan(const canfd_frame& in, std::size_t nbytes, CanFrame& frame) noexcept {
  const bool fd = nbytes == CANFD_MTU;
  if (!fd && nbytes != CAN_MTU) return false;
  std::uint8_t flags = 0;
  std::uint32_t id = 0;
  if ((in.can_id & CAN_ERR_FLAG) != 0) {
    flags = CanFlag::kErrorFrame;
    id = in.can_id & CAN_ERR_MASK;
  } else if ((in.can_id & CAN_EFF_FLAG) != 0) {
    flags = CanFlag::kExtendedId;
    id = in.can_id & CAN_EFF_MASK;
  } else {
    id = in.can_id & CAN_SFF_MASK;
    // An 11-bit frame with bits 11-28 set is not a frame the kernel builds: reject below.
    if ((in.can_id & CAN_EFF_MASK & ~CAN_SFF_MASK) != 0) id = in.can_id & CAN_EFF_MASK;
  }
  if ((in.can_id & CAN_RTR_FLAG) != 0) flags |= CanFlag::kRemote;
  if (fd) {
    flags |= CanFlag::kFd;
    if ((in.flags & CANFD_BRS) != 0) flags |= CanFlag::kBitRateSwitch;
    if ((in.flags & CANFD_ESI) != 0) flags |= CanFlag::kErrorStateIndicator;
  }
  CanFrame f;
  f.id = id;
  f.flags = flags;
  f.len = in.len;
  if (check_frame(f) != FrameError::kNone) return false;
  if (!f.remote()) std::memcpy(f.data.data(), in.data, f.len);
  f.timestamp_ns = frame.timestamp_ns;
  frame = f;
  return true;
}

can_filter to_kernel_filter(const CanFilter& filter) noexcept {
  can_filter k{};
  k.can_id = filter.id & ~CAN_INV_FILTER;
  k.can_mask = filter.mask & ~CAN_ERR_FLAG;
  return k;
}

std::int64_t realtime_to_monotonic_ns(std::int64_t realtime_ns, std::int64_t realtime_now_ns,
                                      std::int64_t mono_now_ns) noexcept {
  const std::int64_t mono = realtime_ns + (mono_now_ns - realtime_now_ns);
  return std::min(mono, mono_now_ns);
}

// ---------------------------------------------------------------------------------------------
// Setup

SocketCanBus::SocketCanBus() noexcept = default;

SocketCanBus::SocketCanBus(std::string_view interface_name, std::span<const CanFilter> filters,
                           const SocketCanOptions& options) {
  open(interface_name, filters, options);
}

SocketCanBus::~SocketCanBus() { close(); }

void SocketCanBus::close() noexcept {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

void SocketCanBus::apply_filters(int fd, std::span<const CanFilter> filters) const {
  check_filters(filters);
  // An empty CAN_RAW_FILTER list receives nothing; CanFilter's empty list passes everything,
  // which is the kernel's default single filter {0, 0}.
  std::vector<can_filter> kernel;
  if (filters.empty()) {
    kernel.push_back(can_filter{0, 0});
  } else {
    kernel.reserve(filters.size());
    for (const CanFilter& f : filters) kernel.push_back(to_kernel_filter(f));
  }
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_FILTER, kernel.data(),
                 static_cast<socklen_t>(kernel.size() * sizeof(can_filter))) != 0) {
    fail(name_, "setsockopt(CAN_RAW_FILTER)", errno);
  }
}

void SocketCanBus::enable_common(int fd) {
  const int flags = fcntl(fd, F_GETFL, 0);
  if (flags < 0 || fcntl(fd, F_SETFL, flags | O_NONBLOCK) != 0) {
    fail(name_, "fcntl(O_NONBLOCK)", errno);
  }
  set_int_option(fd, SOL_SOCKET, SO_TIMESTAMPNS, 1, name_, "setsockopt(SO_TIMESTAMPNS)");
  set_int_option(fd, SOL_SOCKET, SO_RXQ_OVFL, 1, name_, "setsockopt(SO_RXQ_OVFL)");
  if (options_.receive_buffer_bytes > 0) {
    set_int_option(fd, SOL_SOCKET, SO_RCVBUF, options_.receive_buffer_bytes, name_,
                   "setsockopt(SO_RCVBUF)");
  }
}

void SocketCanBus::configure(int fd, std::span<const CanFilter> filters) {
  if (options_.fd_frames) {
    set_int_option(fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, 1, name_, "setsockopt(CAN_RAW_FD_FRAMES)");
  }
  const can_err_mask_t err_mask = options_.error_classes;
  if (setsockopt(fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof(err_mask)) != 0) {
    fail(name_, "setsockopt(CAN_RAW_ERR_FILTER)", errno);
  }
  set_int_option(fd, SOL_CAN_RAW, CAN_RAW_LOOPBACK, options_.loopback ? 1 : 0, name_,
                 "setsockopt(CAN_RAW_LOOPBACK)");
  set_int_option(fd, SOL_CAN_RAW, CAN_RAW_RECV_OWN_MSGS, options_.receive_own_messages ? 1 : 0,
                 name_, "setsockopt(CAN_RAW_RECV_OWN_MSGS)");
  apply_filters(fd, filters);
  enable_common(fd);
}

void SocketCanBus::open(std::string_view interface_name, std::span<const CanFilter> filters,
                        const SocketCanOptions& options) {
  check_options(options);
  check_filters(filters);
  close();
  name_.assign(interface_name);
  options_ = options;
  filters_.assign(filters.begin(), filters.end());
  adopted_ = false;
  if (name_.empty() || name_.size() >= IFNAMSIZ) {
    throw std::invalid_argument("SocketCAN interface name '" + name_ +
                                "' must have 1 to 15 characters");
  }
  const unsigned ifindex = if_nametoindex(name_.c_str());
  if (ifindex == 0) {
    const int err = errno;
    throw std::runtime_error("SocketCAN interface '" + name_ + "' does not exist (" +
                             errno_text(err) + "); create it, e.g. `ip link add dev " + name_ +
                             " type vcan` or check `ip link`");
  }
  const int fd = socket(PF_CAN, SOCK_RAW | SOCK_CLOEXEC, CAN_RAW);
  if (fd < 0) fail(name_, "socket(PF_CAN, SOCK_RAW, CAN_RAW)", errno);
  try {
    configure(fd, filters_);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = static_cast<int>(ifindex);
    if (bind(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof(addr)) != 0) {
      fail(name_, "bind", errno);
    }
  } catch (...) {
    ::close(fd);
    throw;
  }
  fd_ = fd;
  last_drop_count_ = 0;
  link_down_ = false;
  needs_reopen_ = false;
}

void SocketCanBus::adopt(int fd, std::string_view name, const SocketCanOptions& options) {
  if (fd < 0) throw std::invalid_argument("SocketCanBus::adopt: fd must be >= 0");
  check_options(options);
  close();
  name_.assign(name);
  options_ = options;
  filters_.clear();
  adopted_ = true;
  try {
    enable_common(fd);
  } catch (...) {
    ::close(fd);
    throw;
  }
  fd_ = fd;
  last_drop_count_ = 0;
  link_down_ = false;
  needs_reopen_ = false;
}

void SocketCanBus::set_filters(std::span<const CanFilter> filters) {
  check_filters(filters);
  if (fd_ < 0) throw std::runtime_error("SocketCAN interface '" + name_ + "': not open");
  if (adopted_) {
    throw std::runtime_error("SocketCAN socket '" + name_ + "': adopted, filters are its owner's");
  }
  apply_filters(fd_, filters);
  filters_.assign(filters.begin(), filters.end());
}

void SocketCanBus::reopen() {
  if (adopted_) {
    throw std::runtime_error("SocketCAN socket '" + name_ + "': adopted, cannot be reopened");
  }
  if (name_.empty()) throw std::runtime_error("SocketCanBus::reopen: never opened");
  const std::vector<CanFilter> filters = filters_;
  const SocketCanOptions options = options_;
  try {
    open(name_, filters, options);
  } catch (...) {
    close();
    link_down_ = true;
    throw;
  }
  ++extra_.reopens;
}

// ---------------------------------------------------------------------------------------------
// Real-time path

void SocketCanBus::mark_link_down(int err, bool gone) noexcept {
  extra_.last_errno = err;
  if (!link_down_) {
    ++extra_.link_down;
    link_down_since_ns_ = clock_ns(CLOCK_MONOTONIC);
  }
  link_down_ = true;
  if (gone) needs_reopen_ = true;
}

IoStatus SocketCanBus::read(CanFrame& frame) noexcept {
  if (fd_ < 0) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  for (int attempt = 0; attempt < kMaxSkippedPerRead; ++attempt) {
    iovec iov{&rx_frame_, sizeof(rx_frame_)};
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = control_;
    msg.msg_controllen = sizeof(control_);
    const ssize_t n = recvmsg(fd_, &msg, MSG_DONTWAIT);
    if (n < 0) {
      const int err = errno;
      if (err == EAGAIN || err == EWOULDBLOCK) {
        if (link_down_) {
          ++counters_.errors;
          return IoStatus::kError;
        }
        return IoStatus::kWouldBlock;
      }
      if (err == EINTR) continue;
      if (err == ENETDOWN || err == ENODEV || err == ENXIO) {
        mark_link_down(err, err != ENETDOWN);
      } else {
        extra_.last_errno = err;
      }
      ++counters_.errors;
      return IoStatus::kError;
    }
    // Ancillary data: receive time and the socket's running drop count.
    bool have_time = false;
    std::int64_t realtime_ns = 0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
      if (c->cmsg_level != SOL_SOCKET) continue;
      if (c->cmsg_type == SCM_TIMESTAMPNS && c->cmsg_len >= CMSG_LEN(sizeof(timespec))) {
        timespec ts;
        std::memcpy(&ts, CMSG_DATA(c), sizeof(ts));
        realtime_ns = static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
        have_time = true;
      } else if (c->cmsg_type == SO_RXQ_OVFL && c->cmsg_len >= CMSG_LEN(sizeof(std::uint32_t))) {
        std::uint32_t drops;
        std::memcpy(&drops, CMSG_DATA(c), sizeof(drops));
        counters_.dropped += static_cast<std::uint32_t>(drops - last_drop_count_);
        last_drop_count_ = drops;
      }
    }
    if ((msg.msg_flags & MSG_TRUNC) != 0 ||
        !decode_socketcan(rx_frame_, static_cast<std::size_t>(n), frame)) {
      ++extra_.malformed_rx;
      continue;
    }
    std::int64_t mono_now = 0;
    if (have_time) {
      // Realtime read on both sides of the monotonic read, midpoint: the pair's skew is half
      // the window. Up to two more tries while a preemption widened the window beyond 20 us,
      // the narrowest window's pair kept.
      std::int64_t real_now = 0;
      std::int64_t narrowest = std::numeric_limits<std::int64_t>::max();
      for (int pair = 0; pair < 3 && narrowest >= 20'000; ++pair) {
        const std::int64_t r1 = clock_ns(CLOCK_REALTIME);
        const std::int64_t m = clock_ns(CLOCK_MONOTONIC);
        const std::int64_t r2 = clock_ns(CLOCK_REALTIME);
        if (r2 - r1 < narrowest) {
          narrowest = r2 - r1;
          real_now = r1 + (r2 - r1) / 2;
          mono_now = m;
        }
      }
      frame.timestamp_ns = realtime_to_monotonic_ns(realtime_ns, real_now, mono_now);
    } else {
      mono_now = clock_ns(CLOCK_MONOTONIC);
      frame.timestamp_ns = mono_now;
      ++extra_.no_kernel_timestamp;
    }
    // A frame received after the link failed shows the interface up again.
    if (link_down_ && !needs_reopen_ && frame.timestamp_ns > link_down_since_ns_) {
      link_down_ = false;
    }
    if (frame.error_frame()) {
      ++extra_.error_frames;
      const CanErrorReport report = decode_error_frame(frame);
      if (report.bus_off) ++extra_.bus_off;
      if (report.restarted) ++extra_.restarts;
      if (report.controller_overflow) ++extra_.controller_overflows;
      if (report.has_state) state_ = report.state;
    }
    ++counters_.frames_rx;
    return IoStatus::kOk;
  }
  return IoStatus::kWouldBlock;
}

IoStatus SocketCanBus::write(const CanFrame& frame) noexcept {
  canfd_frame out;
  const std::size_t nbytes = fd_ >= 0 ? encode_socketcan(frame, out) : 0;
  if (nbytes == 0 || (frame.fd() && !options_.fd_frames) ||
      (frame.error_frame() && !options_.allow_error_frame_write) || state_ == BusState::kBusOff) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  for (int attempt = 0; attempt < options_.write_attempts;) {
    const ssize_t n = send(fd_, &out, nbytes, MSG_DONTWAIT);
    if (n == static_cast<ssize_t>(nbytes)) {
      if (!needs_reopen_) link_down_ = false;
      ++counters_.frames_tx;
      return IoStatus::kOk;
    }
    const int err = n < 0 ? errno : EIO;  // a short datagram write is a transport failure
    if (err == EINTR) continue;           // not an attempt: the call was interrupted
    if (err == ENOBUFS || err == EAGAIN || err == EWOULDBLOCK) {
      extra_.last_errno = err;
      if (++attempt < options_.write_attempts) ++extra_.tx_retries;
      continue;
    }
    if (err == ENETDOWN || err == ENODEV || err == ENXIO) {
      mark_link_down(err, err != ENETDOWN);
    } else {
      extra_.last_errno = err;
    }
    ++counters_.errors;
    return IoStatus::kError;
  }
  ++counters_.tx_would_block;
  return IoStatus::kWouldBlock;
}

// ---------------------------------------------------------------------------------------------
// Non-real-time helpers

bool SocketCanBus::wait_readable(std::int64_t timeout_ns) const noexcept {
  if (fd_ < 0) return false;
  if (timeout_ns < 0) timeout_ns = 0;
  pollfd p{fd_, POLLIN, 0};
  timespec ts{static_cast<time_t>(timeout_ns / 1'000'000'000),
              static_cast<long>(timeout_ns % 1'000'000'000)};
  return ppoll(&p, 1, &ts, nullptr) > 0 && p.revents != 0;
}

bool SocketCanBus::refresh_link() noexcept {
  if (fd_ < 0 || adopted_) return !link_down_;
  ifreq req{};
  std::memcpy(req.ifr_name, name_.c_str(), std::min(name_.size(), sizeof(req.ifr_name) - 1));
  if (ioctl(fd_, SIOCGIFFLAGS, &req) != 0) {
    const int err = errno;
    mark_link_down(err, err == ENODEV);
    return false;
  }
  // The kernel unbinds a raw socket whose interface was unregistered (ifindex 0): an interface
  // deleted and created again under the same name is up, but this socket no longer sees it.
  sockaddr_can addr{};
  socklen_t len = sizeof(addr);
  if (getsockname(fd_, reinterpret_cast<sockaddr*>(&addr), &len) == 0 && addr.can_ifindex == 0) {
    mark_link_down(ENODEV, true);
    return false;
  }
  if ((req.ifr_flags & IFF_UP) == 0) {
    mark_link_down(ENETDOWN, false);
    return false;
  }
  if (!needs_reopen_) {
    // Consume an ENETDOWN the kernel left on the socket while it was down (SO_ERROR reads and
    // clears sk_err), so the next read() does not report a failure that is over.
    int pending = 0;
    socklen_t plen = sizeof(pending);
    (void)getsockopt(fd_, SOL_SOCKET, SO_ERROR, &pending, &plen);
    link_down_ = false;
  }
  return !link_down_;
}

}  // namespace numen::hal
