#pragma once
/// @file bus.hpp
/// Bus: the non-blocking CAN port interface every transport implements (SimBus, SocketCanBus,
/// SerialBus, LogBus replay, and the RecordingBus decorator). Called from the control period: no call blocks, locks,
/// allocates or throws. Modelled on ros2_control's read/write returning OK/ERROR and on
/// SocketCAN's O_NONBLOCK semantics (EAGAIN -> kWouldBlock, ENOBUFS -> kWouldBlock).

#include <cstdint>

#include "numen/hal/transport/can_frame.hpp"

namespace numen::hal {

/// Result of one Bus read or write.
enum class IoStatus : std::uint8_t {
  kOk,          ///< One frame was read / queued for transmission.
  kWouldBlock,  ///< read: nothing pending. write: transmit queue full (retry next period).
  kError,       ///< The transport failed (bus off, interface down, malformed frame written).
};

/// Fault confinement state of the CAN controller (ISO 11898-1 §12; SocketCAN
/// CAN_STATE_ERROR_ACTIVE / _WARNING / _PASSIVE / BUS_OFF).
enum class BusState : std::uint8_t {
  kOk,            ///< Error active: error counters < 96.
  kErrorWarning,  ///< An error counter >= 96.
  kErrorPassive,  ///< An error counter >= 128: the node may no longer signal errors actively.
  kBusOff,        ///< Transmit error counter > 255: the node is disconnected from the bus.
};

/// Monotonic event counters of one Bus port since construction.
struct BusCounters {
  std::uint64_t frames_rx = 0;       ///< Frames returned by read() with kOk.
  std::uint64_t frames_tx = 0;       ///< Frames accepted by write() with kOk.
  std::uint64_t tx_would_block = 0;  ///< write() calls refused with kWouldBlock (queue full).
  std::uint64_t dropped = 0;         ///< Frames lost before this port could read them
                                     ///< (receive overflow; SimBus: simulated loss).
  std::uint64_t errors = 0;          ///< read()/write() calls that returned kError.
};

/// A CAN port. Implementations are not thread safe unless they say so; one port belongs to
/// one control loop.
class Bus {
 public:
  virtual ~Bus() = default;

  /// Takes the oldest pending received frame into `frame` (its timestamp_ns is the receive
  /// time on the bus clock). kOk: one frame read; kWouldBlock: nothing pending (`frame`
  /// unchanged); kError: transport failure. Never blocks.
  virtual IoStatus read(CanFrame& frame) noexcept = 0;

  /// Queues `frame` for transmission. kOk: queued; kWouldBlock: the transmit queue is full
  /// (the frame is not sent; counted in tx_would_block); kError: transport failure or a
  /// malformed frame (check_frame() != kNone). Bounded time, never blocks.
  virtual IoStatus write(const CanFrame& frame) noexcept = 0;

  /// Current fault confinement state of the controller behind this port.
  virtual BusState state() const noexcept = 0;

  /// Counters of this port.
  virtual BusCounters counters() const noexcept = 0;

 protected:
  Bus() = default;
  Bus(const Bus&) = default;
  Bus& operator=(const Bus&) = default;
};

/// The more severe of two outcomes, for combining several writes into one status: kError,
/// then kWouldBlock, then kOk.
constexpr IoStatus worst(IoStatus a, IoStatus b) noexcept {
  if (a == IoStatus::kError || b == IoStatus::kError) return IoStatus::kError;
  if (a == IoStatus::kWouldBlock || b == IoStatus::kWouldBlock) return IoStatus::kWouldBlock;
  return IoStatus::kOk;
}

/// Short English name of an IoStatus (static string).
const char* to_string(IoStatus status) noexcept;
/// Short English name of a BusState (static string).
const char* to_string(BusState state) noexcept;

}  // namespace numen::hal
