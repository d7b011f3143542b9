/// @file sim_bus.cpp
/// Deterministic simulated CAN bus: two fixed rings, one per direction, on a simulated clock.

#include "numen/hal/transport/sim_bus.hpp"

#include <cmath>
#include <stdexcept>
#include <string>

namespace numen::hal {
namespace {

void check_probability(double p, const char* field) {
  if (!std::isfinite(p) || p < 0.0 || p > 1.0) {
    throw std::invalid_argument(std::string("SimBusSettings.") + field +
                                " must be in [0, 1] (got " + std::to_string(p) + ")");
  }
}

// Valid CAN FD lengths, for length corruption of FD frames.
constexpr std::uint8_t kFdLengths[] = {0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64};

}  // namespace

SimBus::SimBus(const SimBusSettings& settings)
    : settings_(settings),
      controller_(*this, Direction::kControllerToDevice),
      device_(*this, Direction::kDeviceToController) {
  if (settings.latency_ns < 0) {
    throw std::invalid_argument("SimBusSettings.latency_ns must be >= 0 (got " +
                                std::to_string(settings.latency_ns) + ")");
  }
  check_probability(settings.drop_probability, "drop_probability");
  check_probability(settings.corruption_probability, "corruption_probability");
  if (settings.capacity == 0) {
    throw std::invalid_argument("SimBusSettings.capacity must be >= 1 (got 0)");
  }
  // Two independent streams derived from the seed, so each direction's loss and corruption
  // do not depend on how writes of the two directions interleave.
  SplitMix64 seeder(settings.seed);
  for (Link& l : links_) {
    l.ring.resize(settings.capacity);
    l.rng = SplitMix64(seeder.next());
  }
}

std::size_t SimBus::pending(Direction direction) const noexcept { return link(direction).count; }

const SimLinkCounters& SimBus::link_counters(Direction direction) const noexcept {
  return link(direction).counters;
}

void SimBus::corrupt(Link& l, CanFrame& frame) noexcept {
  const std::uint64_t r = l.rng.next();
  if (frame.len > 0 && (r & 1u) == 0) {
    const std::uint32_t bit = static_cast<std::uint32_t>((r >> 1) % (frame.len * 8u));
    frame.data[bit / 8] ^= static_cast<std::uint8_t>(1u << (bit % 8));
    ++l.counters.corrupted_bit;
    return;
  }
  // Another valid length, uniformly among the others.
  if (frame.fd()) {
    constexpr std::uint32_t kCount = sizeof(kFdLengths);
    std::uint32_t current = 0;
    while (current < kCount && kFdLengths[current] != frame.len) ++current;
    std::uint32_t pick = l.rng.below(kCount - 1);
    if (pick >= current) ++pick;
    frame.len = kFdLengths[pick < kCount ? pick : 0];
  } else {
    const std::uint32_t current = frame.len <= kMaxClassicLen ? frame.len : 0;
    std::uint32_t pick = l.rng.below(kMaxClassicLen);  // 0..7, skip current -> 0..8 \ current
    if (pick >= current) ++pick;
    frame.len = static_cast<std::uint8_t>(pick);
  }
  ++l.counters.corrupted_length;
}

IoStatus SimBus::send(Direction direction, const CanFrame& frame) noexcept {
  Link& l = link(direction);
  if (l.count == l.ring.size()) {
    ++l.counters.full;
    return IoStatus::kWouldBlock;
  }
  ++l.counters.written;
  // Always draw both numbers, so the stream does not depend on the probabilities' values.
  const double u_drop = l.rng.uniform();
  const double u_corrupt = l.rng.uniform();
  if (u_drop < settings_.drop_probability) {
    ++l.counters.dropped;
    Port& receiver = direction == Direction::kControllerToDevice ? device_ : controller_;
    ++receiver.counters_.dropped;
    return IoStatus::kOk;
  }
  InFlight& slot = l.ring[(l.head + l.count) % l.ring.size()];
  slot.frame = frame;
  slot.deliver_ns = now_ns_ + settings_.latency_ns;
  if (u_corrupt < settings_.corruption_probability) corrupt(l, slot.frame);
  ++l.count;
  return IoStatus::kOk;
}

IoStatus SimBus::receive(Direction direction, CanFrame& frame, Port& reader) noexcept {
  Link& l = link(direction);
  if (l.count == 0) return IoStatus::kWouldBlock;
  const InFlight& slot = l.ring[l.head];
  if (slot.deliver_ns > now_ns_) return IoStatus::kWouldBlock;
  frame = slot.frame;
  frame.timestamp_ns = slot.deliver_ns;
  l.head = (l.head + 1) % l.ring.size();
  --l.count;
  ++l.counters.delivered;
  ++reader.counters_.frames_rx;
  return IoStatus::kOk;
}

IoStatus SimBus::Port::read(CanFrame& frame) noexcept {
  if (bus_->state_ == BusState::kBusOff) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  const Direction incoming = outgoing_ == Direction::kControllerToDevice
                                 ? Direction::kDeviceToController
                                 : Direction::kControllerToDevice;
  return bus_->receive(incoming, frame, *this);
}

IoStatus SimBus::Port::write(const CanFrame& frame) noexcept {
  if (bus_->state_ == BusState::kBusOff || check_frame(frame) != FrameError::kNone) {
    ++counters_.errors;
    return IoStatus::kError;
  }
  const IoStatus status = bus_->send(outgoing_, frame);
  if (status == IoStatus::kOk) ++counters_.frames_tx;
  if (status == IoStatus::kWouldBlock) ++counters_.tx_would_block;
  return status;
}

BusState SimBus::Port::state() const noexcept { return bus_->state_; }

}  // namespace numen::hal
