/// @file loop_statistics.cpp

#include "numen/platform/loop_statistics.hpp"

#include <algorithm>
#include <cstdio>
#include <stdexcept>

namespace numen::platform {

HistogramSummary summarize(const LatencyHistogram& h) noexcept {
  HistogramSummary s;
  s.count = h.count();
  s.min = h.min();
  s.median = h.quantile(0.5);
  s.p99 = h.quantile(0.99);
  s.p999 = h.quantile(0.999);
  s.max = h.max();
  s.mean = h.mean();
  return s;
}

LoopStatistics::LoopStatistics(std::int64_t period_ns, OverrunPolicy policy,
                               std::int64_t overrun_budget_ns)
    : period_ns_(period_ns), budget_ns_(overrun_budget_ns), policy_(policy) {
  if (period_ns <= 0)
    throw std::invalid_argument("LoopStatistics: period_ns must be > 0 (got " +
                                std::to_string(period_ns) + ")");
  if (overrun_budget_ns < 0)
    throw std::invalid_argument("LoopStatistics: overrun_budget_ns must be >= 0 (got " +
                                std::to_string(overrun_budget_ns) + ")");
  if (policy.action == OverrunAction::kSafeStopAfter && policy.consecutive < 1)
    throw std::invalid_argument(
        "LoopStatistics: OverrunPolicy.consecutive must be >= 1 with kSafeStopAfter (got " +
        std::to_string(policy.consecutive) + ")");
  if (budget_ns_ == 0) budget_ns_ = period_ns;
}

PeriodVerdict LoopStatistics::record_period(const PeriodTimes& t) noexcept {
  PeriodVerdict v;
  const bool ordered = t.deadline_ns <= t.woke_ns && t.woke_ns <= t.sync_sent_ns &&
                       t.sync_sent_ns <= t.input_begin_ns && t.input_begin_ns <= t.input_end_ns &&
                       t.input_end_ns <= t.step_begin_ns && t.step_begin_ns <= t.step_end_ns &&
                       t.step_end_ns <= t.output_begin_ns && t.output_begin_ns <= t.output_end_ns &&
                       t.missed_periods >= 0;
  if (!ordered) {
    ++invalid_;
    v.valid = false;
    v.safe_stop = safe_stop_;
    return v;
  }
  ++periods_;
  skipped_ += t.missed_periods;
  wakeup_.record(t.woke_ns - t.deadline_ns);
  step_.record(t.step_end_ns - t.step_begin_ns);
  bus_io_.record((t.sync_sent_ns - t.woke_ns) + (t.input_end_ns - t.input_begin_ns) +
                 (t.output_end_ns - t.output_begin_ns));
  end_to_end_.record(t.output_end_ns - t.sync_sent_ns);

  v.overrun = t.output_end_ns - t.deadline_ns > budget_ns_;
  if (v.overrun) {
    ++overruns_;
    ++streak_;
    ++policy_streak_;
    longest_streak_ = std::max(longest_streak_, streak_);
    if (policy_.action == OverrunAction::kSafeStopAfter && !safe_stop_ &&
        policy_streak_ >= policy_.consecutive) {
      safe_stop_ = true;
      ++safe_stops_;
    }
  } else {
    streak_ = 0;
    policy_streak_ = 0;
  }
  v.safe_stop = safe_stop_;
  return v;
}

void LoopStatistics::acknowledge_safe_stop() noexcept {
  safe_stop_ = false;
  policy_streak_ = 0;
}

void LoopStatistics::reset() noexcept {
  wakeup_.reset();
  step_.reset();
  bus_io_.reset();
  end_to_end_.reset();
  periods_ = invalid_ = overruns_ = streak_ = longest_streak_ = policy_streak_ = 0;
  skipped_ = safe_stops_ = 0;
  safe_stop_ = false;
}

LoopSummary LoopStatistics::summary() const noexcept {
  LoopSummary s;
  s.period_ns = period_ns_;
  s.overrun_budget_ns = budget_ns_;
  s.periods = periods_;
  s.invalid_periods = invalid_;
  s.overruns = overruns_;
  s.longest_overrun_streak = longest_streak_;
  s.current_overrun_streak = streak_;
  s.skipped_periods = skipped_;
  s.safe_stops = safe_stops_;
  s.safe_stop = safe_stop_;
  s.wakeup = summarize(wakeup_);
  s.step = summarize(step_);
  s.bus_io = summarize(bus_io_);
  s.end_to_end = summarize(end_to_end_);
  return s;
}

namespace {

std::string histogram_line(const char* name, const HistogramSummary& h) {
  char buf[256];
  std::snprintf(buf, sizeof(buf),
                "%s us: min %.1f, median %.1f, p99 %.1f, p99.9 %.1f, max %.1f (%lld periods)", name,
                h.min * 1e-3, h.median * 1e-3, h.p99 * 1e-3, h.p999 * 1e-3, h.max * 1e-3,
                static_cast<long long>(h.count));
  return buf;
}

}  // namespace

std::vector<std::string> describe(const LoopSummary& s) {
  std::vector<std::string> lines;
  char buf[256];
  std::snprintf(buf, sizeof(buf), "period %.1f us, overrun budget %.1f us", s.period_ns * 1e-3,
                s.overrun_budget_ns * 1e-3);
  lines.emplace_back(buf);
  lines.push_back(histogram_line("wake-up latency", s.wakeup));
  lines.push_back(histogram_line("step time", s.step));
  lines.push_back(histogram_line("bus I/O time", s.bus_io));
  lines.push_back(histogram_line("end-to-end (SYNC to torque out)", s.end_to_end));
  std::snprintf(
      buf, sizeof(buf),
      "overruns: %lld (longest streak %lld), skipped periods %lld, invalid periods %lld"
      "%s",
      static_cast<long long>(s.overruns), static_cast<long long>(s.longest_overrun_streak),
      static_cast<long long>(s.skipped_periods), static_cast<long long>(s.invalid_periods),
      s.safe_stops > 0 ? (s.safe_stop ? ", SAFE STOP raised" : ", safe stop raised before") : "");
  lines.emplace_back(buf);
  return lines;
}

}  // namespace numen::platform
