// Tests of numen/hal/device/foaw_estimator.hpp: first-order adaptive windowing (end fit) of one
// encoder axis — the window against a brute-force reading of its definition, exact slopes on
// lines at any intervals, the velocity bound on a jump, wrapped differences, the history's
// capacity, reset, no allocation; and the 2 Hz pivot sine at 1 and 10 kHz (error against the
// true rate below the bare difference's, lag, gain). Simulated time only.
#include "numen/hal/device/foaw_estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <vector>

#include "alloc_counter.hpp"
#include "encoder_sine.hpp"
#include "numen/hal/device/rate_estimator.hpp"
#include "test_constants.hpp"

namespace foaw_estimator_test {  // named: the unity build shares a TU with other test files

using numen::hal::FoawEstimator;
using numen::hal::kFoawMaxWindow;
using numen::test::kMs;
using numen::test::kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();

TEST(FoawEstimator, TheFirstValueOnlyStartsTheHistoryAndOneIntervalIsTheDifference) {
  FoawEstimator f(8, 0.0, kInf, false);
  EXPECT_EQ(f.update(0.25, 0), 0.0);
  EXPECT_FALSE(f.has_rate());
  EXPECT_EQ(f.window(), 0);
  EXPECT_EQ(f.update(0.75, 2 * kMs), (0.75 - 0.25) / 2e-3);
  EXPECT_TRUE(f.has_rate());
  EXPECT_EQ(f.window(), 1);
}

TEST(FoawEstimator, AMaximumWindowOfOneIsTheBoundedBareDifference) {
  FoawEstimator f(1, 1.0, 3.0, false);
  numen::hal::RateEstimator bare(kInf, 3.0, false);
  for (int k = 0; k < 50; ++k) {
    const double x = 1e-3 * k * k * (k % 3 == 0 ? -1.0 : 1.0);
    EXPECT_EQ(f.update(x, k * kMs), bare.update(x, k * kMs)) << k;
  }
  EXPECT_EQ(f.window(), 1);
}

// On a line the window grows to the maximum and the slope is exact, whatever the intervals.
TEST(FoawEstimator, OnALineTheWindowGrowsToTheMaximumAndTheSlopeIsExact) {
  const double slope = -0.4;
  const std::int64_t steps_ns[] = {kMs, kMs / 10, 3 * kMs, kMs, 7 * kMs, kMs / 2, 2 * kMs};
  for (const int n : {4, kFoawMaxWindow}) {
    FoawEstimator f(n, 1e-12, kInf, false);
    std::int64_t t = 0;
    f.update(0.1, t);
    for (int k = 1; k <= 60; ++k) {
      t += steps_ns[k % 7];
      const double v = f.update(0.1 + slope * static_cast<double>(t) * 1e-9, t);
      EXPECT_NEAR(v, slope, 1e-9) << k;
      EXPECT_EQ(f.window(), std::min(k, n)) << k;
    }
  }
}

// The window is the definition's: grown from 1 while every value inside is within ±d of the
// end-fit line, stopped at the first refusal or at the maximum; the estimate is its slope.
TEST(FoawEstimator, TheWindowIsTheLargestWhoseValuesLieWithinTheBand) {
  // Values on a grid of g, band d = g/√2: no deviation (g times a rational) ties with d.
  const double g = 2e-4, d = g / std::sqrt(2.0), dt = 1e-3;
  const int n_max = 16;
  FoawEstimator f(n_max, d, kInf, false);
  std::vector<double> y;
  int long_windows = 0, short_windows = 0;
  for (int k = 0; k < 3000; ++k) {
    const double t = k * dt;
    // A sine with a rounding to the band: the window both grows and shrinks.
    const double x = std::round((0.3 * std::sin(2.0 * kPi * 1.5 * t) +
                                 0.02 * std::sin(2.0 * kPi * 11.0 * t)) / g) * g;
    y.push_back(x);
    const double v = f.update(x, k * kMs);
    if (k == 0) continue;
    const int last = static_cast<int>(y.size()) - 1;
    int window = 1;
    for (int n = 2; n <= std::min(n_max, last); ++n) {
      const double b = (y[last] - y[last - n]) / (n * dt);
      bool inside = true;
      for (int j = 1; j < n; ++j)
        inside = inside && std::abs(y[last - j] - (y[last] - b * j * dt)) <= d;
      if (!inside) break;
      window = n;
    }
    ASSERT_EQ(f.window(), window) << k;
    ASSERT_NEAR(v, (y[last] - y[last - window]) / (window * dt), 1e-9) << k;
    if (window >= 8) ++long_windows;
    if (window <= 3) ++short_windows;
  }
  EXPECT_GT(long_windows, 50);
  EXPECT_GT(short_windows, 50);
}

// A jump that passed the sample checks refuses every window across it but one interval: the
// bound alone limits it, and the next values (still) give 0 and regrow the window.
TEST(FoawEstimator, AJumpFeedsAtMostTheBoundForOnePeriod) {
  const double vmax = 5.0, dt = 1e-3;
  FoawEstimator f(kFoawMaxWindow, 0.5e-6, vmax, false);
  for (int k = 0; k <= 40; ++k) f.update(0.0, k * kMs);
  EXPECT_EQ(f.window(), kFoawMaxWindow);
  double integral = 0.0, peak = 0.0;
  for (int k = 41; k <= 200; ++k) {
    const double v = f.update(1.0, k * kMs);
    peak = std::max(peak, std::abs(v));
    integral += v * dt;
  }
  EXPECT_EQ(peak, vmax);
  EXPECT_NEAR(integral, vmax * dt, 1e-12);
  EXPECT_EQ(f.rate(), 0.0);
  EXPECT_EQ(f.window(), kFoawMaxWindow);
}

TEST(FoawEstimator, TheBoundHoldsForBothSigns) {
  FoawEstimator f(kFoawMaxWindow, 1e-3, 2.0, false);
  f.update(0.0, 0);
  double x = 0.0;
  for (int k = 1; k <= 300; ++k) {
    x += (k % 7 < 3 ? 0.5 : -0.8) * (k % 5 == 0 ? 10.0 : 1e-3);
    ASSERT_LE(std::abs(f.update(x, k * kMs)), 2.0) << k;
  }
}

TEST(FoawEstimator, AWrappingAxisUsesTheWrappedDifferencesOverTheWholeWindow) {
  // 20 rad/s through ±π: every window's slope is the true one.
  FoawEstimator f(kFoawMaxWindow, 1e-9, kInf, true);
  for (int k = 0; k <= 400; ++k) {
    const double v = f.update(numen::hal::wrap_angle(3.0 + 20.0 * k * 1e-3), k * kMs);
    if (k > 0) {
      ASSERT_NEAR(v, 20.0, 1e-6) << k;
    }
  }
  EXPECT_EQ(f.window(), kFoawMaxWindow);
  // Past the 1000 rad rebase of the unwrapped history (an axis spinning for a minute).
  FoawEstimator spin(kFoawMaxWindow, 1e-9, kInf, true);
  for (int k = 0; k <= 60000; ++k) {
    const double v = spin.update(numen::hal::wrap_angle(25.0 * k * 1e-3), k * kMs);
    if (k > 0) {
      ASSERT_NEAR(v, 25.0, 1e-6) << k;
    }
  }
  FoawEstimator plain(kFoawMaxWindow, 1e-9, kInf, false);
  plain.update(kPi - 0.01, 0);
  EXPECT_NEAR(plain.update(-kPi + 0.01, kMs), -(2.0 * kPi - 0.02) / 1e-3, 1e-6);
}

TEST(FoawEstimator, ATimestampNotAfterTheNewestChangesNothing) {
  FoawEstimator f(kFoawMaxWindow, 1e-12, kInf, false);
  f.update(0.0, 0);
  const double v = f.update(1e-3, kMs);
  EXPECT_EQ(f.update(5.0, kMs), v);
  EXPECT_EQ(f.update(5.0, kMs / 2), v);
  EXPECT_NEAR(f.update(2e-3, 2 * kMs), 1.0, 1e-12);  // the line 0, 1e-3, 2e-3: window 2
  EXPECT_EQ(f.window(), 2);
}

TEST(FoawEstimator, ResetForgetsTheHistoryAndTheEstimate) {
  FoawEstimator f(kFoawMaxWindow, 1e-6, kInf, false);
  for (int k = 0; k < 10; ++k) f.update(1e-3 * k, k * kMs);
  ASSERT_NE(f.rate(), 0.0);
  f.reset();
  EXPECT_EQ(f.rate(), 0.0);
  EXPECT_FALSE(f.has_rate());
  EXPECT_EQ(f.update(7.0, 100 * kMs), 0.0);  // a new history, no difference across the reset
  EXPECT_NEAR(f.update(7.001, 101 * kMs), 1.0, 1e-9);
  EXPECT_EQ(f.window(), 1);
}

TEST(FoawEstimator, TheMaximumWindowIsClampedToTheCapacity) {
  EXPECT_EQ(FoawEstimator(0, 0.0, kInf, false).max_window(), 1);
  EXPECT_EQ(FoawEstimator(1000, 0.0, kInf, false).max_window(), kFoawMaxWindow);
  EXPECT_EQ(FoawEstimator().max_window(), kFoawMaxWindow);
}

TEST(FoawEstimator, UpdateDoesNotAllocate) {
  FoawEstimator f(kFoawMaxWindow, 1e-4, 10.0, true);
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 10000; ++k) f.update(std::sin(1e-3 * k), k * kMs / 10);
    f.reset();
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
}

// ---- A 2 Hz sine on the default trocar's pivot encoder (2^14 counts per turn) ----

namespace sine = numen::test::encoder_sine;

sine::SineRun run_foaw(double dt, double noise_counts = numen::hal::kDefaultFoawNoiseCounts) {
  return sine::run_sine(
      [&] { return FoawEstimator(kFoawMaxWindow, noise_counts * sine::kCount, 10.0, false); }, dt);
}

sine::SineRun run_bare(double dt) {
  return sine::run_sine([] { return numen::hal::RateEstimator(kInf, 10.0, false); }, dt);
}

// Against the true rate, with the default band (the half count): below the bare difference's
// error at both rates. With a band of one count (the end-fit line's own endpoints are off by up
// to q/2 each, so a point of a straight motion can lie q from it) the window reaches the
// maximum on the straight parts: a tenth of the bare difference's error at 10 kHz.
TEST(FoawEstimatorSine, ErrorAgainstTheTrueRateIsBelowTheBareDifferencesAtOneAndTenKilohertz) {
  for (const double dt : {1e-3, 1e-4}) {
    const sine::SineRun half = run_foaw(dt);
    const sine::SineRun one = run_foaw(dt, 1.0);
    const sine::SineRun bare = run_bare(dt);
    std::printf("[   info   ] %g kHz: error rms against the true rate: FOAW d = 0.5 count %.4f "
                "rad/s (lag %.3f ms), d = 1 count %.4f (lag %.3f ms); bare difference %.4f\n",
                1e-3 / dt, half.error_rms, half.lag_s * 1e3, one.error_rms, one.lag_s * 1e3,
                bare.error_rms);
    EXPECT_LT(half.error_rms, 0.8 * bare.error_rms) << dt;
    EXPECT_LT(one.error_rms, 0.8 * bare.error_rms) << dt;
  }
  EXPECT_LT(run_foaw(1e-4, 1.0).error_rms, 0.1 * run_bare(1e-4).error_rms);
}

// The end fit's lag is half its window: on the exact sine a fraction of the longest window.
TEST(FoawEstimatorSine, LagAndGainOnA2HzSine) {
  for (const double dt : {1e-3, 1e-4}) {
    const sine::SineRun f = run_foaw(dt);
    EXPECT_GT(f.lag_s, 0.0) << dt;
    EXPECT_LE(f.lag_s, 0.5 * kFoawMaxWindow * dt * (1.0 + 1e-9)) << dt;
    EXPECT_NEAR(f.gain, 1.0, 2e-3) << dt;
  }
}

}  // namespace foaw_estimator_test
