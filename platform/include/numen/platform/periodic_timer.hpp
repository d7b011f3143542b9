#pragma once
/// @file periodic_timer.hpp
/// Fixed-period wake-ups on absolute CLOCK_MONOTONIC deadlines
/// (clock_nanosleep with TIMER_ABSTIME): no drift accumulates, a late period
/// is reported as an overrun instead of being hidden. Optionally the wait ends in a short
/// busy-wait on the clock (spin), for a loop on a CPU of its own on a kernel without
/// PREEMPT_RT (docs/realtime.md "Spinning the end of the wait").

#include <atomic>
#include <cstdint>

namespace numen::platform {

/// Longest slice of a paced loop's sleep while a stop can be requested (ns): how late a stop
/// request is heard in a period longer than two of them (PeriodicTimer::wait_next(stop, …)).
inline constexpr std::int64_t kStopSliceNs = 10'000'000;

/// Result of one wait.
struct Wakeup {
  std::int64_t deadline_ns = 0;  ///< The absolute deadline that was waited for.
  std::int64_t woke_ns = 0;      ///< When the thread actually resumed.
  std::int64_t missed_periods = 0;  ///< Whole periods skipped because the caller was late.
  /// The caller reached wait_next() after the deadline: the previous period
  /// overran (counted even when less than a whole period late).
  bool overrun = false;
  /// wait_next(stop, slice_ns) returned early on a stop request: no deadline was waited for
  /// (deadline_ns is the one that is still next), the caller should not run a period.
  bool stopped = false;
  /// Wake-up latency woke_ns − deadline_ns (ns); with overrun, how late.
  std::int64_t latency_ns() const noexcept { return woke_ns - deadline_ns; }
};

/// Periodic timer on CLOCK_MONOTONIC. Not thread-safe; one per loop.
class PeriodicTimer {
 public:
  /// period_ns > 0. The first deadline is start_ns + period_ns.
  PeriodicTimer(std::int64_t period_ns, std::int64_t start_ns) noexcept;
  /// Sleeps until the next deadline. If the caller is already past it by one
  /// or more whole periods, the missed deadlines are skipped (counted in
  /// missed_periods) so the loop re-phases instead of bursting.
  Wakeup wait_next() noexcept;
  /// As wait_next(), but a stop request is heard during a long period: while the deadline is
  /// more than 2 × `slice_ns` away it sleeps in slices of `slice_ns` and returns as soon as
  /// `*stop` is true (Wakeup::stopped, the deadline kept for a later call; also at once when
  /// it is true on entry); the last 1–2 slices are wait_next()'s one sleep, so without a stop
  /// a period is paced exactly as by wait_next(). `stop` nullptr or `slice_ns` <= 0:
  /// wait_next().
  Wakeup wait_next(const std::atomic<bool>* stop, std::int64_t slice_ns) noexcept;
  /// The period (ns).
  std::int64_t period_ns() const noexcept { return period_ns_; }
  /// The wait sleeps until `spin_ns` before each deadline, then reads CLOCK_MONOTONIC in a
  /// loop until the deadline: the wake-up's own latency (the kernel's timer, the scheduler)
  /// is taken before the deadline instead of after it, at the price of a CPU busy for up to
  /// `spin_ns` a period. 0 (the default): one clock_nanosleep to the deadline. Clamped to
  /// [0, period]. Meant for a thread on a CPU no other thread uses.
  void set_spin_ns(std::int64_t spin_ns) noexcept;
  /// The spin of set_spin_ns() (ns).
  std::int64_t spin_ns() const noexcept { return spin_ns_; }

 private:
  std::int64_t period_ns_;
  std::int64_t next_ns_;
  std::int64_t spin_ns_ = 0;
};

}  // namespace numen::platform
