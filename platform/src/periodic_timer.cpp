/// @file periodic_timer.cpp

#include "numen/platform/periodic_timer.hpp"

#include <cerrno>
#include <time.h>

#include "numen/platform/monotonic_clock.hpp"

namespace numen::platform {

PeriodicTimer::PeriodicTimer(std::int64_t period_ns, std::int64_t start_ns) noexcept
    : period_ns_(period_ns > 0 ? period_ns : 1), next_ns_(start_ns + period_ns_) {}

Wakeup PeriodicTimer::wait_next() noexcept {
  Wakeup w;
  const std::int64_t now = monotonic_now_ns();
  w.overrun = now > next_ns_;
  if (now > next_ns_ + period_ns_) {  // late by at least one whole period: skip, do not burst
    w.missed_periods = (now - next_ns_) / period_ns_;
    next_ns_ += w.missed_periods * period_ns_;
  }
  w.deadline_ns = next_ns_;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(next_ns_ / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(next_ns_ % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  w.woke_ns = monotonic_now_ns();
  next_ns_ += period_ns_;
  return w;
}

}  // namespace numen::platform
