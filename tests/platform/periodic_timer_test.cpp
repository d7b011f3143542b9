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

#include <time.h>

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

namespace {

std::int64_t thread_cpu_ns() {
  timespec ts{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

}  // namespace

// The spin (set_spin_ns, `numen run --spin`): the wait sleeps to spin_ns before the deadline
// and reads the clock until it, on this thread's CPU: never before the deadline, and the spin
// is CPU time of the waiting thread (a sleep to the deadline takes almost none).
TEST(PeriodicTimer, ASpinEndsTheWaitAtTheDeadlineOnTheWaitingThreadsCpu) {
  constexpr std::int64_t kPeriod = 10'000'000, kSpin = 5'000'000;  // 10 ms periods, 5 ms spin
  PeriodicTimer timer(kPeriod, monotonic_now_ns());
  EXPECT_EQ(timer.spin_ns(), 0);
  timer.set_spin_ns(kSpin);
  EXPECT_EQ(timer.spin_ns(), kSpin);
  const std::int64_t cpu0 = thread_cpu_ns();
  for (int k = 0; k < 10; ++k) {
    const Wakeup w = timer.wait_next();
    EXPECT_GE(w.woke_ns, w.deadline_ns) << "period " << k;
  }
  const std::int64_t spun = thread_cpu_ns() - cpu0;
  std::printf("[   info   ] 10 periods with a 5 ms spin: %.1f ms of the thread's CPU time\n",
              static_cast<double>(spun) * 1e-6);
  // 50 ms of spin in all: at least a tenth of it on a machine shared with other work.
  EXPECT_GT(spun, 5'000'000);
  // Clamped to [0, period].
  timer.set_spin_ns(-5);
  EXPECT_EQ(timer.spin_ns(), 0);
  timer.set_spin_ns(3 * kPeriod);
  EXPECT_EQ(timer.spin_ns(), kPeriod);
}
