#pragma once
/// @file periodic_timer.hpp
/// Fixed-period wake-ups on absolute CLOCK_MONOTONIC deadlines
/// (clock_nanosleep with TIMER_ABSTIME): no drift accumulates, a late period
/// is reported as an overrun instead of being hidden.

#include <cstdint>

namespace numen::platform {

/// Result of one wait.
struct Wakeup {
  std::int64_t deadline_ns = 0;  ///< The absolute deadline that was waited for.
  std::int64_t woke_ns = 0;      ///< When the thread actually resumed.
  std::int64_t missed_periods = 0;  ///< Whole periods skipped because the caller was late.
  /// The caller reached wait_next() after the deadline: the previous period
  /// overran (counted even when less than a whole period late).
  bool overrun = false;
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
  /// The period (ns).
  std::int64_t period_ns() const noexcept { return period_ns_; }

 private:
  std::int64_t period_ns_;
  std::int64_t next_ns_;
};

}  // namespace numen::platform
