/// @file serial_bus.cpp
/// Bus over a POSIX tty: termios raw 8N1 setup, non-blocking read/decode, buffered
/// non-blocking write with partial-write continuation.

#include "numen/hal/transport/serial_bus.hpp"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <cerrno>
#include <cstring>
#include <ctime>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

struct BaudCode {
  std::uint32_t baud;
  speed_t code;
};

// Linux termios speeds from 9600 bit/s up (asm-generic/termbits.h).
constexpr BaudCode kBaudCodes[] = {
    {9600, B9600},       {19200, B19200},     {38400, B38400},     {57600, B57600},
    {115200, B115200},   {230400, B230400},   {460800, B460800},   {500000, B500000},
    {576000, B576000},   {921600, B921600},   {1000000, B1000000}, {1152000, B1152000},
    {1500000, B1500000}, {2000000, B2000000}, {2500000, B2500000}, {3000000, B3000000},
    {3500000, B3500000}, {4000000, B4000000},
};
constexpr std::size_t kBaudCount = sizeof(kBaudCodes) / sizeof(kBaudCodes[0]);

constexpr std::array<std::uint32_t, kBaudCount> make_baud_list() noexcept {
  std::array<std::uint32_t, kBaudCount> list{};
  for (std::size_t i = 0; i < kBaudCount; ++i) list[i] = kBaudCodes[i].baud;
  return list;
}
constexpr std::array<std::uint32_t, kBaudCount> kBauds = make_baud_list();

speed_t speed_code(const std::string& path, std::uint32_t baud) {
  for (const BaudCode& b : kBaudCodes) {
    if (b.baud == baud) return b.code;
  }
  std::string supported;
  for (const BaudCode& b : kBaudCodes) {
    if (!supported.empty()) supported += ", ";
    supported += std::to_string(b.baud);
  }
  throw std::invalid_argument("SerialBus " + path + ": unsupported baud rate " +
                              std::to_string(baud) + " (supported: " + supported + ")");
}

[[noreturn]] void throw_errno(const std::string& path, const char* call, int err) {
  throw std::runtime_error("SerialBus " + path + ": " + call + " failed: " + std::strerror(err));
}

// Raw 8N1, no flow control, reads that never wait (see serial_bus.hpp).
void configure(int fd, const std::string& path, speed_t speed) {
  if (::ioctl(fd, TIOCEXCL) != 0) throw_errno(path, "ioctl(TIOCEXCL)", errno);
  termios tio{};
  if (::tcgetattr(fd, &tio) != 0) throw_errno(path, "tcgetattr", errno);
  ::cfmakeraw(&tio);
  tio.c_cflag &= ~static_cast<tcflag_t>(CSIZE | PARENB | CSTOPB | CRTSCTS);
  tio.c_cflag |= CS8 | CLOCAL | CREAD;
  tio.c_iflag &= ~static_cast<tcflag_t>(IXON | IXOFF | IXANY);
  tio.c_cc[VMIN] = 1;
  tio.c_cc[VTIME] = 0;
  if (::cfsetispeed(&tio, speed) != 0) throw_errno(path, "cfsetispeed", errno);
  if (::cfsetospeed(&tio, speed) != 0) throw_errno(path, "cfsetospeed", errno);
  if (::tcsetattr(fd, TCSANOW, &tio) != 0) throw_errno(path, "tcsetattr", errno);
  // tcsetattr succeeds if any change was made: read back what the driver kept.
  termios got{};
  if (::tcgetattr(fd, &got) != 0) throw_errno(path, "tcgetattr", errno);
  if (::cfgetospeed(&got) != speed || ::cfgetispeed(&got) != speed) {
    throw std::runtime_error("SerialBus " + path + ": the driver did not accept the baud rate");
  }
  constexpr tcflag_t kFraming = CSIZE | PARENB | CSTOPB | CRTSCTS;
  if ((got.c_cflag & kFraming) != CS8 || (got.c_iflag & (IXON | IXOFF)) != 0 ||
      (got.c_lflag & (ICANON | ECHO | ISIG)) != 0 || (got.c_oflag & OPOST) != 0) {
    throw std::runtime_error("SerialBus " + path +
                             ": the driver did not accept raw 8N1 without flow control");
  }
  if (::tcflush(fd, TCIOFLUSH) != 0) throw_errno(path, "tcflush", errno);
}

std::int64_t monotonic_ns() noexcept {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

std::span<const std::uint32_t> serial_supported_bauds() noexcept { return kBauds; }

SerialBus::SerialBus(const std::string& path, std::uint32_t baud,
                     std::span<const CanFilter> filters)
    : path_(path), baud_(baud), filters_(filters.begin(), filters.end()) {
  const speed_t speed = speed_code(path, baud);
  fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) throw_errno(path, "open", errno);
  try {
    configure(fd_, path, speed);
  } catch (...) {
    ::close(fd_);
    fd_ = -1;
    throw;
  }
}

SerialBus::~SerialBus() {
  if (fd_ >= 0) ::close(fd_);
}

IoStatus SerialBus::fail_io(int err) noexcept {
  last_error_ = err;
  if (err == 0 || err == EIO || err == ENXIO) line_gone_ = true;
  ++counters_.errors;
  return IoStatus::kError;
}

IoStatus SerialBus::read(CanFrame& frame) noexcept {
  if (line_gone_) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  int reads = 0;
  for (;;) {
    while (rx_begin_ < rx_end_) {
      CanFrame f;
      const SerialFrameDecoder::Result r = decoder_.feed(
          std::span<const std::uint8_t>(rx_.data() + rx_begin_, rx_end_ - rx_begin_), f);
      rx_begin_ += r.consumed;
      if (!r.frame_ready) break;
      if (!passes(filters_, f)) {
        ++filtered_;
        continue;
      }
      f.timestamp_ns = rx_time_ns_;
      frame = f;
      ++counters_.frames_rx;
      return IoStatus::kOk;
    }
    rx_begin_ = 0;
    rx_end_ = 0;
    if (reads == kMaxReadsPerCall) return IoStatus::kWouldBlock;
    ++reads;
    const ssize_t n = ::read(fd_, rx_.data(), rx_.size());
    if (n > 0) {
      rx_time_ns_ = monotonic_ns();
      rx_end_ = static_cast<std::size_t>(n);
      continue;
    }
    if (n == 0) return fail_io(0);  // hang-up (VMIN = 1: an empty line gives EAGAIN)
    const int err = errno;
    if (err == EAGAIN || err == EWOULDBLOCK) return IoStatus::kWouldBlock;
    if (err == EINTR) continue;  // counts against kMaxReadsPerCall
    return fail_io(err);
  }
}

IoStatus SerialBus::write_pending() noexcept {
  if (tx_begin_ == tx_end_) return IoStatus::kOk;
  const ssize_t n = ::write(fd_, tx_.data() + tx_begin_, tx_end_ - tx_begin_);
  if (n < 0) {
    const int err = errno;
    if (err == EAGAIN || err == EWOULDBLOCK || err == EINTR) return IoStatus::kWouldBlock;
    return fail_io(err);
  }
  tx_begin_ += static_cast<std::size_t>(n);
  if (tx_begin_ == tx_end_) {
    tx_begin_ = 0;
    tx_end_ = 0;
    return IoStatus::kOk;
  }
  return IoStatus::kWouldBlock;
}

IoStatus SerialBus::write(const CanFrame& frame) noexcept {
  if (line_gone_) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  std::array<std::uint8_t, kSerialMaxFrameOnLine> encoded;
  const SerialEncodeResult e = encode_serial_frame(frame, encoded);
  if (!e.ok()) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  if (write_pending() == IoStatus::kError) return IoStatus::kError;
  if (tx_pending() + e.length > kTxBufferSize) {
    ++counters_.tx_would_block;
    return IoStatus::kWouldBlock;
  }
  if (tx_end_ + e.length > kTxBufferSize) {  // compact: pending bytes to the front
    std::memmove(tx_.data(), tx_.data() + tx_begin_, tx_pending());
    tx_end_ -= tx_begin_;
    tx_begin_ = 0;
  }
  std::memcpy(tx_.data() + tx_end_, encoded.data(), e.length);
  tx_end_ += e.length;
  if (write_pending() == IoStatus::kError) return IoStatus::kError;
  ++counters_.frames_tx;
  return IoStatus::kOk;
}

IoStatus SerialBus::flush() noexcept {
  if (line_gone_) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  return write_pending();
}

BusCounters SerialBus::counters() const noexcept {
  BusCounters c = counters_;
  c.dropped = decoder_.counters().rejected();
  return c;
}

SerialCounters SerialBus::serial_counters() const noexcept {
  SerialCounters c = decoder_.counters();
  c.filtered = filtered_;
  return c;
}

}  // namespace numen::hal
