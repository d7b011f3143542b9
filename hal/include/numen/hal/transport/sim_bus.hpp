#pragma once
/// @file sim_bus.hpp
/// SimBus: a deterministic in-process CAN bus between a controller and a device, with
/// latency, loss and corruption, on a simulated clock. It stands in for a real bus in tests
/// and in simulated instruments; its two ports are ordinary Bus objects, so code written
/// against Bus runs unchanged on SocketCAN (socketcan_bus.hpp).

#include <cstddef>
#include <cstdint>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_frame.hpp"
#include "numen/hal/transport/splitmix64.hpp"

namespace numen::hal {

/// Creation settings of a SimBus. Checked by the SimBus constructor.
struct SimBusSettings {
  /// Transit time, ns, >= 0: a frame written at bus time t is readable from t + latency_ns.
  std::int64_t latency_ns = 0;
  /// Probability in [0, 1] that a written frame is lost in transit (write still returns kOk,
  /// as on a bus where the receiver overflows; counted as dropped).
  double drop_probability = 0.0;
  /// Probability in [0, 1] that a delivered frame is corrupted: one random payload bit is
  /// flipped or its length is changed to another valid length (one or the other with equal
  /// odds; always the length for an empty frame). Models a faulty node or a lost CRC check.
  double corruption_probability = 0.0;
  /// Seed of the loss/corruption generators: same seed and same calls -> identical runs.
  std::uint64_t seed = 0;
  /// Frames in flight per direction, >= 1. The rings are allocated once at construction;
  /// a full ring makes write() return kWouldBlock.
  std::size_t capacity = 256;
};

/// Counters of one direction of a SimBus since construction.
struct SimLinkCounters {
  std::uint64_t written = 0;           ///< Frames accepted into this direction (write kOk).
  std::uint64_t delivered = 0;         ///< Frames read out at the far port.
  std::uint64_t dropped = 0;           ///< Frames lost on purpose (drop_probability).
  std::uint64_t corrupted_bit = 0;     ///< Frames with one payload bit flipped.
  std::uint64_t corrupted_length = 0;  ///< Frames whose length was changed.
  std::uint64_t full = 0;              ///< Writes refused because the ring was full.
  /// Total corrupted frames (bit flips + length changes).
  std::uint64_t corrupted() const noexcept { return corrupted_bit + corrupted_length; }
};

/// A deterministic simulated CAN bus with two ports. Frames written on controller() are read
/// on device() and vice versa, in write order, each after `latency_ns` of simulated time.
/// The clock only moves with set_time_ns(); a delivered frame's timestamp_ns is its delivery
/// time (write time + latency). Not thread safe; not copyable or movable (the ports point back
/// to it). read/write never allocate, throw, lock or block.
class SimBus {
 public:
  /// The two directions of the bus.
  enum class Direction : std::uint8_t {
    kControllerToDevice = 0,  ///< Written on controller(), read on device().
    kDeviceToController = 1,  ///< Written on device(), read on controller().
  };

  /// One end of the SimBus; a Bus.
  class Port final : public Bus {
   public:
    /// Reads the oldest frame of the incoming direction whose delivery time <= bus time.
    /// kWouldBlock if none; kError while the bus state is kBusOff.
    IoStatus read(CanFrame& frame) noexcept override;
    /// Sends `frame` in the outgoing direction at the current bus time. kError if the frame
    /// is malformed (check_frame()) or the bus is off; kWouldBlock if that direction's ring is
    /// full. A frame lost to drop_probability still returns kOk.
    IoStatus write(const CanFrame& frame) noexcept override;
    /// The state set by SimBus::set_state() (kOk by default).
    BusState state() const noexcept override;
    /// Counters of this port; `dropped` counts frames lost on their way to this port.
    BusCounters counters() const noexcept override { return counters_; }

   private:
    friend class SimBus;
    Port(SimBus& bus, Direction outgoing) noexcept : bus_(&bus), outgoing_(outgoing) {}
    SimBus* bus_;
    Direction outgoing_;
    BusCounters counters_{};
  };

  /// Allocates both rings. Throws std::invalid_argument naming the field if latency_ns < 0,
  /// a probability is outside [0, 1] or not finite, or capacity == 0.
  explicit SimBus(const SimBusSettings& settings);
  SimBus(const SimBus&) = delete;
  SimBus& operator=(const SimBus&) = delete;
  SimBus(SimBus&&) = delete;
  SimBus& operator=(SimBus&&) = delete;

  /// The controller's port (writes SYNC and torque RPDOs, reads encoder TPDOs).
  Port& controller() noexcept { return controller_; }
  /// The device's port (reads SYNC and RPDOs, writes TPDOs).
  Port& device() noexcept { return device_; }

  /// Sets the simulated bus clock, ns. Meant to be non-decreasing; frames already in flight
  /// keep their delivery time.
  void set_time_ns(std::int64_t t_ns) noexcept { now_ns_ = t_ns; }
  /// Current simulated bus time, ns.
  std::int64_t time_ns() const noexcept { return now_ns_; }

  /// Simulates a controller state (for tests of error handling). kBusOff makes every read
  /// and write return kError; the other states only change state().
  void set_state(BusState state) noexcept { state_ = state; }

  /// Frames in flight in `direction` (delivered or not yet).
  std::size_t pending(Direction direction) const noexcept;
  /// Counters of `direction`.
  const SimLinkCounters& link_counters(Direction direction) const noexcept;
  /// The settings the bus was built with.
  const SimBusSettings& settings() const noexcept { return settings_; }

 private:
  struct InFlight {
    CanFrame frame;
    std::int64_t deliver_ns = 0;
  };
  struct Link {
    std::vector<InFlight> ring;
    std::size_t head = 0;
    std::size_t count = 0;
    SplitMix64 rng;
    SimLinkCounters counters;
  };

  IoStatus send(Direction direction, const CanFrame& frame) noexcept;
  IoStatus receive(Direction direction, CanFrame& frame, Port& reader) noexcept;
  void corrupt(Link& link, CanFrame& frame) noexcept;
  Link& link(Direction d) noexcept { return links_[static_cast<int>(d)]; }
  const Link& link(Direction d) const noexcept { return links_[static_cast<int>(d)]; }

  SimBusSettings settings_;
  Link links_[2];
  std::int64_t now_ns_ = 0;
  BusState state_ = BusState::kOk;
  Port controller_;
  Port device_;
};

}  // namespace numen::hal
