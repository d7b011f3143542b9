#pragma once
/// @file serial_bus.hpp
/// SerialBus: a Bus over a POSIX serial line (a USB-serial adapter, a UART, a pseudo-terminal),
/// carrying CanFrames in the framing of serial_frame.hpp (COBS + CRC-16, 0x00-delimited).
///
/// The line is opened O_RDWR | O_NOCTTY | O_NONBLOCK and set raw (termios cfmakeraw():
/// no echo, no CR/LF translation, no signals, no XON/XOFF) with CLOCAL | CREAD, 8 data bits,
/// no parity, 1 stop bit, no hardware flow control, VMIN = 1 / VTIME = 0 (with O_NONBLOCK:
/// an empty read fails with EAGAIN, and a read of 0 bytes means hang-up). Exclusive use is
/// requested (TIOCEXCL) and bytes left in the driver are flushed (tcflush TCIOFLUSH).
///
/// Mapping onto Bus (a serial line has no ISO 11898 fault confinement):
/// - state(): kOk while the line is up; kBusOff once the line is gone — read(2) returned 0
///   (hang-up: USB adapter unplugged, pseudo-terminal master closed) or read/write failed with
///   EIO or ENXIO. Sticky: every later read/write returns kError; construct a new SerialBus
///   to reopen. kErrorWarning and kErrorPassive are never reported.
/// - counters().dropped: rejected chunks (SerialCounters::rejected()): damaged frames lost on
///   the line, plus any garbage. Filtered frames are not dropped.
/// - read/write return kError, counted in counters().errors, for a gone line, an unexpected
///   errno, or (write) a malformed frame.

#include <array>
#include <cstddef>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/serial_frame.hpp"

namespace numen::hal {

/// The line speeds SerialBus accepts, bit/s: the termios speeds B9600 … B4000000 of Linux
/// (asm-generic/termbits.h), in increasing order.
std::span<const std::uint32_t> serial_supported_bauds() noexcept;

/// A CAN port over a serial line. Not thread safe; not copyable or movable (it owns the file
/// descriptor and fixed buffers). read/write/flush never allocate, throw, lock or block.
class SerialBus final : public Bus {
 public:
  /// Receive buffer for one read(2), bytes.
  static constexpr std::size_t kRxBufferSize = 1024;
  /// Transmit buffer (bytes encoded but not yet accepted by the driver), bytes.
  static constexpr std::size_t kTxBufferSize = 1024;
  /// At most this many read(2) calls per read(): bounded time under a flood of bytes.
  static constexpr int kMaxReadsPerCall = 4;

  /// Opens and configures the tty at `path` at `baud` bit/s (one of serial_supported_bauds()).
  /// Received frames pass if any of `filters` matches (CanFilter semantics; empty: all pass).
  /// Throws std::invalid_argument for an unsupported baud (naming it and the path), and
  /// std::runtime_error naming the path, the failing call and strerror(errno) if the line
  /// cannot be opened or configured (including a driver that does not take the speed).
  SerialBus(const std::string& path, std::uint32_t baud, std::span<const CanFilter> filters = {});
  /// Closes the line (close(2) may wait while the driver sends bytes it already holds).
  ~SerialBus() override;
  SerialBus(const SerialBus&) = delete;
  SerialBus& operator=(const SerialBus&) = delete;
  SerialBus(SerialBus&&) = delete;
  SerialBus& operator=(SerialBus&&) = delete;

  /// Returns the oldest frame received and not yet returned that passes the filters.
  /// Decodes bytes already read first; when they hold no complete frame, reads what the
  /// driver has (non-blocking, at most kMaxReadsPerCall read(2) calls). The frame's
  /// timestamp_ns is CLOCK_MONOTONIC, ns, taken right after the read(2) that delivered its
  /// delimiter (a tty gives no arrival time). kWouldBlock: no complete frame yet (a partial
  /// frame is kept for the next call; `frame` unchanged). kError: line gone (state kBusOff)
  /// or unexpected errno.
  IoStatus read(CanFrame& frame) noexcept override;

  /// Encodes `frame` into the transmit buffer and writes what the driver takes. Bytes left
  /// by a partial write are written first on the next write() (or flush()). kOk: queued;
  /// kWouldBlock: the pending bytes plus this frame do not fit kTxBufferSize (nothing queued;
  /// counted in tx_would_block); kError: malformed frame (check_frame() or reserved flags),
  /// line gone, or unexpected errno. timestamp_ns is not sent.
  IoStatus write(const CanFrame& frame) noexcept override;

  /// Writes pending transmit bytes. kOk: none left; kWouldBlock: some left (driver full);
  /// kError: line gone or unexpected errno.
  IoStatus flush() noexcept;

  /// kOk, or kBusOff once the line is gone (see the file comment).
  BusState state() const noexcept override {
    return line_gone_ ? BusState::kBusOff : BusState::kOk;
  }

  /// Bus counters; dropped = serial_counters().rejected().
  BusCounters counters() const noexcept override;

  /// Decoder counters plus the frames filtered out by this port.
  SerialCounters serial_counters() const noexcept;

  /// Encoded bytes waiting for the driver.
  std::size_t tx_pending() const noexcept { return tx_end_ - tx_begin_; }

  /// The file descriptor (for poll()/epoll in an event loop; do not read or write it).
  int native_handle() const noexcept { return fd_; }

  /// errno of the last kError (0 for a hang-up, or none yet): strerror() it outside the
  /// control period.
  int last_error() const noexcept { return last_error_; }

  /// Path the line was opened at.
  const std::string& path() const noexcept { return path_; }

  /// Line speed, bit/s.
  std::uint32_t baud() const noexcept { return baud_; }

 private:
  IoStatus fail_io(int err) noexcept;
  IoStatus write_pending() noexcept;

  std::string path_;
  std::uint32_t baud_;
  std::vector<CanFilter> filters_;
  int fd_ = -1;
  bool line_gone_ = false;
  int last_error_ = 0;
  SerialFrameDecoder decoder_;
  std::array<std::uint8_t, kRxBufferSize> rx_{};
  std::size_t rx_begin_ = 0;
  std::size_t rx_end_ = 0;
  std::int64_t rx_time_ns_ = 0;
  std::array<std::uint8_t, kTxBufferSize> tx_{};
  std::size_t tx_begin_ = 0;
  std::size_t tx_end_ = 0;
  BusCounters counters_{};
  std::uint64_t filtered_ = 0;
};

}  // namespace numen::hal
