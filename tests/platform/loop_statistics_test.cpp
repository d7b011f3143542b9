// LoopStatistics: the derived durations of a period, percentiles against exact order
// statistics of a known distribution, the overrun policies, rejected timestamps, and no
// allocation over 100k periods.
#include "numen/platform/loop_statistics.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <memory>
#include <random>
#include <stdexcept>
#include <vector>

#include "alloc_counter.hpp"

using numen::platform::LoopStatistics;
using numen::platform::LoopSummary;
using numen::platform::OverrunAction;
using numen::platform::OverrunPolicy;
using numen::platform::PeriodTimes;
using numen::platform::PeriodVerdict;

namespace {

constexpr std::int64_t kPeriod = 1'000'000;  // 1 kHz

/// Durations of the phases of one period (ns).
struct Phases {
  std::int64_t wake = 5'000;        // woke − deadline
  std::int64_t sync_write = 2'000;  // sync_sent − woke
  std::int64_t wait = 100'000;      // input_begin − sync_sent (encoders answering)
  std::int64_t read = 3'000;        // input_end − input_begin
  std::int64_t decode = 1'000;      // step_begin − input_end
  std::int64_t step = 200'000;      // step_end − step_begin
  std::int64_t prepare = 1'000;     // output_begin − step_end
  std::int64_t write = 4'000;       // output_end − output_begin
};

PeriodTimes period_at(std::int64_t k, const Phases& p) {
  PeriodTimes t;
  t.deadline_ns = 1'000'000'000 + k * kPeriod;
  t.woke_ns = t.deadline_ns + p.wake;
  t.sync_sent_ns = t.woke_ns + p.sync_write;
  t.input_begin_ns = t.sync_sent_ns + p.wait;
  t.input_end_ns = t.input_begin_ns + p.read;
  t.step_begin_ns = t.input_end_ns + p.decode;
  t.step_end_ns = t.step_begin_ns + p.step;
  t.output_begin_ns = t.step_end_ns + p.prepare;
  t.output_end_ns = t.output_begin_ns + p.write;
  return t;
}

/// A period whose torque goes out `late` ns after its deadline (late > kPeriod: overrun).
PeriodTimes ending_at(std::int64_t k, std::int64_t late) {
  Phases p;
  p.step = late - (p.wake + p.sync_write + p.wait + p.read + p.decode + p.prepare + p.write);
  return period_at(k, p);
}

std::int64_t exact_quantile(std::vector<std::int64_t> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::ceil(q * static_cast<double>(v.size()))) - 1];
}

}  // namespace

TEST(LoopStatistics, DerivesTheFourDurationsOfAPeriod) {
  LoopStatistics stats(kPeriod);
  const PeriodVerdict v = stats.record_period(period_at(0, Phases{}));
  EXPECT_TRUE(v.valid);
  EXPECT_FALSE(v.overrun);
  EXPECT_FALSE(v.safe_stop);
  const LoopSummary s = stats.summary();
  EXPECT_EQ(s.periods, 1);
  EXPECT_EQ(s.wakeup.max, 5'000);
  EXPECT_EQ(s.step.max, 200'000);
  EXPECT_EQ(s.bus_io.max, 2'000 + 3'000 + 4'000);  // SYNC write + reads + torque writes
  // SYNC sent → torque out: wait + read + decode + step + prepare + write.
  EXPECT_EQ(s.end_to_end.max, 100'000 + 3'000 + 1'000 + 200'000 + 1'000 + 4'000);
  EXPECT_EQ(s.end_to_end.min, s.end_to_end.max);
  EXPECT_EQ(s.overrun_budget_ns, kPeriod);
}

TEST(LoopStatistics, PercentilesMatchExactOrderStatistics) {
  std::mt19937_64 rng(42);
  std::lognormal_distribution<double> wake(std::log(8'000.0), 0.6);  // ~8 µs, long tail
  std::uniform_int_distribution<std::int64_t> step(150'000, 450'000);
  std::exponential_distribution<double> io(1.0 / 6'000.0);
  constexpr int kN = 100'000;
  std::vector<std::int64_t> w(kN), st(kN), e2e(kN);
  auto stats = std::make_unique<LoopStatistics>(kPeriod);
  for (int k = 0; k < kN; ++k) {
    Phases p;
    p.wake = static_cast<std::int64_t>(wake(rng));
    p.step = step(rng);
    p.write = static_cast<std::int64_t>(io(rng));
    w[k] = p.wake;
    st[k] = p.step;
    e2e[k] = p.wait + p.read + p.decode + p.step + p.prepare + p.write;
    ASSERT_TRUE(stats->record_period(period_at(k, p)).valid);
  }
  const LoopSummary s = stats->summary();
  struct Check {
    const char* name;
    const std::vector<std::int64_t>* exact;
    numen::platform::HistogramSummary got;
  };
  for (const Check& c : {Check{"wakeup", &w, s.wakeup}, Check{"step", &st, s.step},
                         Check{"end_to_end", &e2e, s.end_to_end}}) {
    SCOPED_TRACE(c.name);
    EXPECT_EQ(c.got.count, kN);
    EXPECT_EQ(c.got.min, *std::min_element(c.exact->begin(), c.exact->end()));
    EXPECT_EQ(c.got.max, *std::max_element(c.exact->begin(), c.exact->end()));
    const std::pair<double, std::int64_t> qs[] = {
        {0.5, c.got.median}, {0.99, c.got.p99}, {0.999, c.got.p999}};
    for (const auto& [q, got] : qs) {
      const std::int64_t exact = exact_quantile(*c.exact, q);
      EXPECT_GE(got, exact) << q;
      EXPECT_LE(got, exact + exact / 32 + 1) << q;  // LatencyHistogram resolution
    }
  }
  // The uniform step time: median ≈ 300 µs, p99 ≈ 447 µs (within resolution and sampling).
  EXPECT_NEAR(static_cast<double>(s.step.median), 300'000.0, 300'000.0 / 32 + 2'000);
  EXPECT_NEAR(static_cast<double>(s.step.p99), 447'000.0, 447'000.0 / 32 + 2'000);
}

TEST(LoopStatistics, RecordingDoesNotAllocateOver100kPeriods) {
  auto stats = std::make_unique<LoopStatistics>(kPeriod, OverrunPolicy::safe_stop_after(3));
  std::vector<PeriodTimes> periods;
  for (std::int64_t k = 0; k < 100'000; ++k) {
    Phases p;
    p.wake = 1'000 + (k * 7919) % 50'000;
    p.step = 100'000 + (k * 104729) % 900'000;  // some periods overrun
    periods.push_back(period_at(k, p));
  }
  std::int64_t overruns = 0;
  numen::test::AllocationGuard guard;
  for (const PeriodTimes& t : periods) overruns += stats->record_period(t).overrun ? 1 : 0;
  const LoopSummary s = stats->summary();
  EXPECT_EQ(guard.count(), 0);
  EXPECT_EQ(s.periods, 100'000);
  EXPECT_EQ(s.overruns, overruns);
  EXPECT_GT(overruns, 0);
}

TEST(LoopStatistics, CountPolicyCountsOverrunsAndStreaksButNeverStops) {
  LoopStatistics stats(kPeriod, OverrunPolicy::count());
  // pattern: ok, over, over, ok, over, over, over, over, ok, over
  const bool pattern[] = {false, true, true, false, true, true, true, true, false, true};
  std::int64_t k = 0;
  for (bool over : pattern) {
    const PeriodVerdict v = stats.record_period(ending_at(k++, over ? 1'200'000 : 800'000));
    EXPECT_EQ(v.overrun, over) << k;
    EXPECT_FALSE(v.safe_stop);
  }
  const LoopSummary s = stats.summary();
  EXPECT_EQ(s.overruns, 7);
  EXPECT_EQ(s.longest_overrun_streak, 4);
  EXPECT_EQ(s.current_overrun_streak, 1);
  EXPECT_EQ(s.safe_stops, 0);
  EXPECT_FALSE(s.safe_stop);
}

TEST(LoopStatistics, SafeStopAfterNConsecutiveOverrunsLatchesUntilAcknowledged) {
  LoopStatistics stats(kPeriod, OverrunPolicy::safe_stop_after(3));
  std::int64_t k = 0;
  auto over = [&] { return stats.record_period(ending_at(k++, 1'500'000)); };
  auto ok = [&] { return stats.record_period(ending_at(k++, 500'000)); };
  EXPECT_FALSE(over().safe_stop);
  EXPECT_FALSE(over().safe_stop);
  EXPECT_FALSE(ok().safe_stop);  // the streak is broken
  EXPECT_FALSE(over().safe_stop);
  EXPECT_FALSE(over().safe_stop);
  const PeriodVerdict third = over();
  EXPECT_TRUE(third.overrun);
  EXPECT_TRUE(third.safe_stop);  // exactly at the third in a row
  EXPECT_TRUE(ok().safe_stop);   // latched: good timing does not lower it
  EXPECT_TRUE(stats.safe_stop());
  stats.acknowledge_safe_stop();
  EXPECT_FALSE(stats.safe_stop());
  EXPECT_FALSE(over().safe_stop);  // counting starts again after the acknowledge
  EXPECT_FALSE(over().safe_stop);
  EXPECT_TRUE(over().safe_stop);
  const LoopSummary s = stats.summary();
  EXPECT_EQ(s.safe_stops, 2);
  EXPECT_TRUE(s.safe_stop);
  EXPECT_EQ(s.overruns, 8);
  EXPECT_EQ(s.longest_overrun_streak, 3);
}

TEST(LoopStatistics, SafeStopAfterOneStopsAtTheFirstOverrun) {
  LoopStatistics stats(kPeriod, OverrunPolicy::safe_stop_after(1));
  EXPECT_FALSE(stats.record_period(ending_at(0, kPeriod)).safe_stop);  // = budget: on time
  EXPECT_TRUE(stats.record_period(ending_at(1, kPeriod + 1)).safe_stop);
}

TEST(LoopStatistics, OverrunBudgetShorterThanThePeriod) {
  LoopStatistics stats(kPeriod, OverrunPolicy::count(), 800'000);
  EXPECT_FALSE(stats.record_period(ending_at(0, 800'000)).overrun);
  EXPECT_TRUE(stats.record_period(ending_at(1, 800'001)).overrun);
  EXPECT_EQ(stats.summary().overrun_budget_ns, 800'000);
}

TEST(LoopStatistics, DisorderedTimestampsAreRejectedAndCounted) {
  LoopStatistics stats(kPeriod, OverrunPolicy::safe_stop_after(2));
  EXPECT_TRUE(stats.record_period(ending_at(0, 1'500'000)).overrun);
  PeriodTimes bad = ending_at(1, 1'500'000);
  bad.step_end_ns = bad.step_begin_ns - 1;  // a step that ended before it began
  const PeriodVerdict v = stats.record_period(bad);
  EXPECT_FALSE(v.valid);
  EXPECT_FALSE(v.overrun);
  PeriodTimes early = period_at(2, Phases{});
  early.woke_ns = early.deadline_ns - 1;  // woke before the deadline
  early.missed_periods = 0;
  EXPECT_FALSE(stats.record_period(early).valid);
  PeriodTimes negative = period_at(3, Phases{});
  negative.missed_periods = -1;
  EXPECT_FALSE(stats.record_period(negative).valid);
  const LoopSummary s = stats.summary();
  EXPECT_EQ(s.invalid_periods, 3);
  EXPECT_EQ(s.periods, 1);
  EXPECT_EQ(s.step.count, 1);
  EXPECT_EQ(s.current_overrun_streak, 1);  // unchanged by the rejected periods
  EXPECT_FALSE(s.safe_stop);
}

TEST(LoopStatistics, SkippedPeriodsAreSummed) {
  LoopStatistics stats(kPeriod);
  PeriodTimes t = period_at(0, Phases{});
  t.missed_periods = 3;
  stats.record_period(t);
  t = period_at(5, Phases{});
  t.missed_periods = 2;
  stats.record_period(t);
  EXPECT_EQ(stats.summary().skipped_periods, 5);
  stats.reset();
  EXPECT_EQ(stats.summary().skipped_periods, 0);
  EXPECT_EQ(stats.summary().wakeup.count, 0);
}

TEST(LoopStatistics, ConstructorRejectsBadSettings) {
  EXPECT_THROW(LoopStatistics(0), std::invalid_argument);
  EXPECT_THROW(LoopStatistics(kPeriod, OverrunPolicy::count(), -1), std::invalid_argument);
  try {
    LoopStatistics(kPeriod, OverrunPolicy::safe_stop_after(0));
    FAIL() << "no exception";
  } catch (const std::invalid_argument& e) {
    EXPECT_NE(std::string(e.what()).find("OverrunPolicy.consecutive must be >= 1"),
              std::string::npos);
  }
}

TEST(LoopStatistics, DescribeGivesMicroseconds) {
  LoopStatistics stats(kPeriod, OverrunPolicy::safe_stop_after(1));
  stats.record_period(period_at(0, Phases{}));
  stats.record_period(ending_at(1, 1'500'000));
  const auto lines = numen::platform::describe(stats.summary());
  ASSERT_EQ(lines.size(), 6u);
  EXPECT_EQ(lines[0], "period 1000.0 us, overrun budget 1000.0 us");
  EXPECT_EQ(lines[1].rfind("wake-up latency us: min 5.0, median 5.0", 0), 0u) << lines[1];
  EXPECT_EQ(lines[3],
            "bus I/O time us: min 9.0, median 9.0, p99 9.0, p99.9 9.0, max 9.0 (2 periods)");
  EXPECT_EQ(lines[5],
            "overruns: 1 (longest streak 1), skipped periods 0, invalid periods 0, SAFE STOP "
            "raised");
}
