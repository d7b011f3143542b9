/// @file bus_share.cpp
/// BusShare: the ports, their rings and the fan-out of the shared bus's frames.

#include "numen/hal/transport/bus_share.hpp"

#include <stdexcept>
#include <utility>

namespace numen::hal {

/// One port of a BusShare: a ring of the frames its filters passed, read oldest first.
class BusShare::Port final : public Bus {
 public:
  Port(BusShare& share, std::vector<CanFilter> filters)
      : share_(&share), filters_(std::move(filters)), ring_(share.capacity_) {}

  IoStatus read(CanFrame& frame) noexcept override {
    share_->pump();
    if (size_ > 0) {
      frame = ring_[head_];
      head_ = (head_ + 1) % ring_.size();
      --size_;
      ++counters_.frames_rx;
      return IoStatus::kOk;
    }
    if (error_) {
      error_ = false;
      ++counters_.errors;
      return IoStatus::kError;
    }
    return IoStatus::kWouldBlock;
  }

  IoStatus write(const CanFrame& frame) noexcept override {
    const IoStatus s = share_->bus_->write(frame);
    if (s == IoStatus::kOk) ++counters_.frames_tx;
    if (s == IoStatus::kWouldBlock) ++counters_.tx_would_block;
    if (s == IoStatus::kError) ++counters_.errors;
    return s;
  }

  BusState state() const noexcept override { return share_->bus_->state(); }
  BusCounters counters() const noexcept override { return counters_; }

  // The fan-out's side.
  void offer(const CanFrame& frame) noexcept {
    if (!passes(filters_, frame)) return;
    if (size_ == ring_.size()) {  // full: the oldest frame is lost
      head_ = (head_ + 1) % ring_.size();
      --size_;
      ++counters_.dropped;
    }
    ring_[(head_ + size_) % ring_.size()] = frame;
    ++size_;
  }
  void mark_error() noexcept { error_ = true; }

 private:
  BusShare* share_;
  std::vector<CanFilter> filters_;
  std::vector<CanFrame> ring_;
  std::size_t head_ = 0;
  std::size_t size_ = 0;
  bool error_ = false;
  BusCounters counters_;
};

BusShare::BusShare(Bus& bus, std::size_t capacity) : bus_(&bus), capacity_(capacity) {
  if (capacity == 0) throw std::invalid_argument("BusShare: capacity must be > 0");
}

BusShare::~BusShare() = default;

Bus& BusShare::add_port(std::vector<CanFilter> filters) {
  ports_.push_back(std::make_unique<Port>(*this, std::move(filters)));
  return *ports_.back();
}

Bus& BusShare::port(std::size_t i) noexcept { return *ports_[i]; }

void BusShare::pump() noexcept {
  CanFrame frame;
  // At most one ring's worth per call: a flooding bus cannot hold the period here.
  for (std::size_t n = 0; n < capacity_; ++n) {
    const IoStatus s = bus_->read(frame);
    if (s == IoStatus::kOk) {
      for (const std::unique_ptr<Port>& p : ports_) p->offer(frame);
      continue;
    }
    if (s == IoStatus::kError)
      for (const std::unique_ptr<Port>& p : ports_) p->mark_error();
    return;
  }
}

}  // namespace numen::hal
