#include "numen/hal/input/evemu_replay.hpp"

#include <algorithm>
#include <limits>
#include <stdexcept>
#include <string>
#include <utility>

namespace numen::hal {

EvemuReplay::EvemuReplay(std::vector<InputEvent> events, std::int64_t offset_ns)
    : events_(std::move(events)), offset_ns_(offset_ns) {
  if (!events_.empty()) {
    first_ns_ = events_.front().time_ns;
    std::int64_t latest = first_ns_;
    for (const InputEvent& e : events_) latest = std::max(latest, e.time_ns);
    span_ns_ = latest - first_ns_;
    if (offset_ns_ > 0 && span_ns_ > std::numeric_limits<std::int64_t>::max() - offset_ns_) {
      throw std::invalid_argument("EvemuReplay: offset_ns " + std::to_string(offset_ns_) +
                                  " + recording span " + std::to_string(span_ns_) +
                                  " ns overflows int64");
    }
  }
  latest_due_ns_ = offset_ns_;
}

std::int64_t EvemuReplay::next_due_ns() const noexcept {
  if (finished()) return latest_due_ns_;
  const std::int64_t rel = events_[cursor_].time_ns - first_ns_;
  // Out of order (negative or earlier than the previous): due right after the predecessor.
  return std::max(offset_ns_ + std::max<std::int64_t>(rel, 0), latest_due_ns_);
}

bool EvemuReplay::read(InputEvent& event) noexcept {
  if (finished()) return false;
  const std::int64_t due = next_due_ns();
  if (due > now_ns_) return false;
  event = events_[cursor_];
  event.time_ns = due;
  latest_due_ns_ = due;
  ++cursor_;
  return true;
}

std::size_t EvemuReplay::feed(RelativePoseIntegrator& integrator) noexcept {
  std::size_t n = 0;
  InputEvent e;
  while (read(e)) {
    integrator.feed(e);
    ++n;
  }
  return n;
}

}  // namespace numen::hal
