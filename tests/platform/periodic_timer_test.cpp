// Tests of platform::PeriodicTimer (periodic_timer.hpp): the stop-aware wait hears a stop
// request within a slice in a long period, keeps the deadline for the next call, and paces a
// period as wait_next() does when no stop comes.

#include "numen/platform/periodic_timer.hpp"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstdint>
#include <cstdio>
#include <thread>

#include "numen/platform/monotonic_clock.hpp"

namespace {

using numen::platform::kStopSliceNs;
using numen::platform::monotonic_now_ns;
using numen::platform::PeriodicTimer;
using numen::platform::Wakeup;

TEST(PeriodicTimer, AStopInALongPeriodIsHeardWithinASliceAndTheDeadlineIsKept) {
  constexpr std::int64_t kPeriod = 400'000'000;  // 0.4 s: twenty slices
  const std::int64_t start = monotonic_now_ns();
  PeriodicTimer timer(kPeriod, start);
  std::atomic<bool> stop{false};
  std::int64_t stop_at = 0;
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(60));
    stop_at = monotonic_now_ns();
    stop.store(true);
  });
  const Wakeup w = timer.wait_next(&stop, kStopSliceNs);
  stopper.join();
  std::printf("[   info   ] stop heard %.1f ms after it was set\n",
              static_cast<double>(w.woke_ns - stop_at) * 1e-6);
  EXPECT_TRUE(w.stopped);
  EXPECT_FALSE(w.overrun);
  EXPECT_EQ(w.deadline_ns, start + kPeriod) << "the deadline is still the next one";
  EXPECT_LT(w.woke_ns, start + kPeriod - 100'000'000) << "it waited for the deadline";
  // Without a stop the same deadline is waited for: not before it, and not reported late.
  stop.store(false);
  const Wakeup next = timer.wait_next(&stop, kStopSliceNs);
  EXPECT_FALSE(next.stopped);
  EXPECT_EQ(next.deadline_ns, start + kPeriod);
  EXPECT_GE(next.woke_ns, start + kPeriod);
  EXPECT_FALSE(next.overrun);
  EXPECT_EQ(next.missed_periods, 0);
}

TEST(PeriodicTimer, WithoutAStopFlagItIsWaitNext) {
  const std::int64_t start = monotonic_now_ns();
  PeriodicTimer timer(20'000'000, start);
  const Wakeup w = timer.wait_next(nullptr, kStopSliceNs);
  EXPECT_FALSE(w.stopped);
  EXPECT_EQ(w.deadline_ns, start + 20'000'000);
  EXPECT_GE(w.woke_ns, w.deadline_ns);
  const Wakeup v = timer.wait_next(nullptr, 0);
  EXPECT_EQ(v.deadline_ns, start + 40'000'000);
  EXPECT_GE(v.woke_ns, v.deadline_ns);
}

}  // namespace
