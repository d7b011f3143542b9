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
  const std::int64_t sleep_until = next_ns_ - spin_ns_;
  timespec ts{};
  ts.tv_sec = static_cast<time_t>(sleep_until / 1'000'000'000);
  ts.tv_nsec = static_cast<long>(sleep_until % 1'000'000'000);
  while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
  }
  w.woke_ns = monotonic_now_ns();
  while (w.woke_ns < next_ns_) w.woke_ns = monotonic_now_ns();  // spin_ns_ > 0: the spin
  next_ns_ += period_ns_;
  return w;
}

void PeriodicTimer::set_spin_ns(std::int64_t spin_ns) noexcept {
  spin_ns_ = spin_ns < 0 ? 0 : (spin_ns > period_ns_ ? period_ns_ : spin_ns);
}

Wakeup PeriodicTimer::wait_next(const std::atomic<bool>* stop, std::int64_t slice_ns) noexcept {
  if (stop != nullptr && slice_ns > 0) {
    for (;;) {
      const std::int64_t now = monotonic_now_ns();
      if (stop->load(std::memory_order_relaxed)) {
        Wakeup w;
        w.stopped = true;
        w.deadline_ns = next_ns_;
        w.woke_ns = now;
        return w;
      }
      if (next_ns_ - now <= 2 * slice_ns) break;
      const std::int64_t until = now + slice_ns;
      const timespec ts{static_cast<time_t>(until / 1'000'000'000),
                        static_cast<long>(until % 1'000'000'000)};
      clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);  // EINTR: look again
    }
  }
  return wait_next();
}

}  // namespace numen::platform
