#pragma once
/// @file bus_share.hpp
/// BusShare: several ports over one Bus, for several devices (or several device emulators) on
/// one CAN. Every frame read from the shared bus is copied to each port whose acceptance
/// filters pass it (can_filter.hpp), as each SocketCAN CAN_RAW socket bound to one interface
/// receives its own copy of every frame its CAN_RAW_FILTER list passes (linux/can/raw.h);
/// writes go straight to the shared bus. Without it, the first device to read a point-to-point
/// port (SimBus, LogBus) would take the other device's frames too. Construction allocates;
/// every port operation is noexcept, allocation free, lock free and never blocks. Not thread
/// safe: the ports belong to one control loop (one thread).

#include <cstddef>
#include <cstdint>
#include <memory>
#include <vector>

#include "numen/hal/transport/bus.hpp"
#include "numen/hal/transport/can_filter.hpp"

namespace numen::hal {

/// Several ports over one Bus (see the file comment).
class BusShare {
 public:
  /// Keeps a reference: `bus` must outlive the share and its ports. `capacity` (> 0): frames
  /// each port holds between two of its reads (the oldest frame is dropped beyond it, counted
  /// in that port's BusCounters::dropped). Throws std::invalid_argument if capacity is 0.
  explicit BusShare(Bus& bus, std::size_t capacity = 1024);
  ~BusShare();
  BusShare(const BusShare&) = delete;
  BusShare& operator=(const BusShare&) = delete;

  /// Adds a port that receives the frames `filters` pass (empty: every frame; error reports
  /// always pass, as in can_filter.hpp's passes()). Construction only (allocates); the
  /// reference stays valid for the share's life.
  Bus& add_port(std::vector<CanFilter> filters);

  /// The number of ports.
  std::size_t num_ports() const noexcept { return ports_.size(); }
  /// Port `i` (< num_ports()).
  Bus& port(std::size_t i) noexcept;
  /// The shared bus.
  const Bus& bus() const noexcept { return *bus_; }

 private:
  class Port;
  // Reads the shared bus until nothing is pending and copies each frame to the ports that
  // pass it; a kError marks every port (each returns it once, after its pending frames).
  void pump() noexcept;

  Bus* bus_;
  std::size_t capacity_;
  std::vector<std::unique_ptr<Port>> ports_;
};

}  // namespace numen::hal
