#pragma once
/// @file loop_statistics.hpp
/// Timing statistics of the real-time loop, recorded every period without allocation:
/// histograms (LatencyHistogram) of wake-up latency, step time, bus I/O time and end-to-end
/// latency (SYNC sent → encoder frames in → step → torque frames out), overrun counting and
/// the overrun policy that tells the loop when to drive its safe state.
///
/// One period, as the loop stamps it (all CLOCK_MONOTONIC ns, monotonic_now_ns()):
///
///   deadline ─ woke ─[SYNC write]─ sync_sent ··· (encoders answer) ···
///     input_begin ─[read frames]─ input_end ─ step_begin ─[core::step]─ step_end ─
///     output_begin ─[torque writes]─ output_end
///
///   wake-up latency = woke − deadline
///   step time       = step_end − step_begin
///   bus I/O time    = (sync_sent − woke) + (input_end − input_begin) + (output_end − output_begin)
///   end-to-end      = output_end − sync_sent  (the encoder values latched at SYNC reach the
///                     drives as torque this much later: the loop's transport delay)
///   overrun         = output_end − deadline > overrun budget (default: one period), i.e. the
///                     torque went out after the next period should have started.

#include <cstdint>
#include <string>
#include <vector>

#include "numen/platform/latency_histogram.hpp"

namespace numen::platform {

/// Timestamps of one period (CLOCK_MONOTONIC ns; see the file comment for the order). They
/// must be non-decreasing in the order listed; a period whose stamps are not is rejected
/// (counted in LoopSummary::invalid_periods, nothing else recorded).
struct PeriodTimes {
  std::int64_t deadline_ns = 0;      ///< The timer's deadline (Wakeup::deadline_ns).
  std::int64_t woke_ns = 0;          ///< When the thread resumed (Wakeup::woke_ns).
  std::int64_t sync_sent_ns = 0;     ///< The SYNC write returned (after begin_period).
  std::int64_t input_begin_ns = 0;   ///< Reading the encoder frames started.
  std::int64_t input_end_ns = 0;     ///< The encoder frames were read.
  std::int64_t step_begin_ns = 0;    ///< core::step started.
  std::int64_t step_end_ns = 0;      ///< core::step returned.
  std::int64_t output_begin_ns = 0;  ///< The torque writes started.
  std::int64_t output_end_ns = 0;    ///< The torque writes returned.
  /// Whole periods the timer skipped before this one (Wakeup::missed_periods); summed in
  /// LoopSummary::skipped_periods.
  std::int64_t missed_periods = 0;
};

/// What the loop does about overruns.
enum class OverrunAction {
  /// Count them and keep going.
  kCount,
  /// Count them; after `consecutive` overruns in a row, raise safe_stop. The flag latches:
  /// it stays raised (and record_period keeps returning it) until acknowledge_safe_stop().
  /// The loop must then drive its safe state (zero torque, drives to "quick stop" /
  /// "disable operation", CiA 402 §6.3) instead of the computed torques.
  kSafeStopAfter,
};

/// The overrun policy. Checked by the LoopStatistics constructor.
struct OverrunPolicy {
  OverrunAction action = OverrunAction::kCount;
  /// For kSafeStopAfter: consecutive overruns that raise safe_stop, >= 1.
  int consecutive = 0;

  static OverrunPolicy count() noexcept { return {}; }
  static OverrunPolicy safe_stop_after(int n) noexcept {
    return {OverrunAction::kSafeStopAfter, n};
  }
};

/// Result of record_period().
struct PeriodVerdict {
  bool valid = true;       ///< The timestamps were ordered (else nothing was recorded).
  bool overrun = false;    ///< This period overran its budget.
  bool safe_stop = false;  ///< Drive the safe state now (kSafeStopAfter; latched).
};

/// min / median / p99 / p99.9 / max of one histogram (ns).
struct HistogramSummary {
  std::int64_t count = 0;
  std::int64_t min = 0;
  std::int64_t median = 0;
  std::int64_t p99 = 0;
  std::int64_t p999 = 0;
  std::int64_t max = 0;
  double mean = 0.0;
};

/// HistogramSummary of `h` (quantiles at LatencyHistogram resolution, ≤ 3.2 % above).
HistogramSummary summarize(const LatencyHistogram& h) noexcept;

/// Everything the statistics hold, at the time of summary().
struct LoopSummary {
  std::int64_t period_ns = 0;               ///< The loop period.
  std::int64_t overrun_budget_ns = 0;       ///< output_end − deadline above this is an overrun.
  std::int64_t periods = 0;                 ///< Valid periods recorded.
  std::int64_t invalid_periods = 0;         ///< Periods rejected for disordered timestamps.
  std::int64_t overruns = 0;                ///< Periods that overran.
  std::int64_t longest_overrun_streak = 0;  ///< Most consecutive overruns.
  std::int64_t current_overrun_streak = 0;  ///< Consecutive overruns up to the last period.
  std::int64_t skipped_periods = 0;         ///< Sum of PeriodTimes::missed_periods.
  std::int64_t safe_stops = 0;              ///< Times safe_stop was raised.
  bool safe_stop = false;                   ///< safe_stop is raised now.
  HistogramSummary wakeup;                  ///< woke − deadline.
  HistogramSummary step;                    ///< step_end − step_begin.
  HistogramSummary bus_io;                  ///< SYNC write + frame reads + torque writes.
  HistogramSummary end_to_end;              ///< output_end − sync_sent.
};

/// Human-readable lines of a summary, in µs, e.g.
///   "wake-up latency us: min 2.1, median 4.0, p99 11.3, p99.9 25.0, max 41.2 (1000 periods)"
///   "overruns: 0 (longest streak 0), skipped periods 0, invalid periods 0"
std::vector<std::string> describe(const LoopSummary& summary);

/// The loop's timing statistics. Construct at setup (about 40 KiB: keep it on the heap or
/// as a member, not on the real-time stack); record_period() every period. Not thread-safe:
/// read summary() from the loop thread, or after the loop stopped.
class LoopStatistics {
 public:
  /// period_ns > 0; overrun_budget_ns > 0 or 0 for "one period". Throws
  /// std::invalid_argument naming the field (period_ns, overrun_budget_ns,
  /// policy.consecutive < 1 with kSafeStopAfter).
  LoopStatistics(std::int64_t period_ns, OverrunPolicy policy = OverrunPolicy::count(),
                 std::int64_t overrun_budget_ns = 0);

  /// Records one period. noexcept, no allocation, no lock, O(1).
  PeriodVerdict record_period(const PeriodTimes& t) noexcept;
  /// Lowers a latched safe_stop (an operator's decision after the cause is understood) and
  /// restarts the consecutive-overrun count.
  void acknowledge_safe_stop() noexcept;
  /// safe_stop is raised.
  bool safe_stop() const noexcept { return safe_stop_; }
  /// Clears every count and histogram and a latched safe_stop.
  void reset() noexcept;

  /// The summary (min/median/p99/p99.9/max per histogram, overruns, streaks).
  LoopSummary summary() const noexcept;

  const LatencyHistogram& wakeup() const noexcept { return wakeup_; }
  const LatencyHistogram& step() const noexcept { return step_; }
  const LatencyHistogram& bus_io() const noexcept { return bus_io_; }
  const LatencyHistogram& end_to_end() const noexcept { return end_to_end_; }
  const OverrunPolicy& policy() const noexcept { return policy_; }

 private:
  std::int64_t period_ns_;
  std::int64_t budget_ns_;
  OverrunPolicy policy_;
  LatencyHistogram wakeup_;
  LatencyHistogram step_;
  LatencyHistogram bus_io_;
  LatencyHistogram end_to_end_;
  std::int64_t periods_ = 0;
  std::int64_t invalid_ = 0;
  std::int64_t overruns_ = 0;
  std::int64_t streak_ = 0;
  std::int64_t longest_streak_ = 0;
  std::int64_t policy_streak_ = 0;  // consecutive overruns since the last acknowledge
  std::int64_t skipped_ = 0;
  std::int64_t safe_stops_ = 0;
  bool safe_stop_ = false;
};

}  // namespace numen::platform
