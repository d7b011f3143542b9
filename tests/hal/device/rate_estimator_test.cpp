// Tests of numen/hal/device/rate_estimator.hpp: the bounded first-order filtered backward
// difference of one encoder axis — exact discretisation for any sample interval, the velocity
// bound, wrapped differences, the quantisation bound α q / Δt on a quantised 2 Hz sine at
// 1 and 10 kHz (the default trocar's 14-bit pivot), and the lag on a sine against
// group_delay_s(). Simulated time only: no timed assertion.
#include "numen/hal/device/rate_estimator.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <limits>
#include <numbers>

#include "alloc_counter.hpp"
#include "encoder_sine.hpp"
#include "numen/hal/device/axis.hpp"
#include "test_constants.hpp"

namespace {

using numen::hal::kDefaultVelocityCutoffHz;
using numen::hal::RateEstimator;
using numen::test::kPi;
constexpr double kInf = std::numeric_limits<double>::infinity();
using numen::test::kMs;

TEST(RateEstimator, WithoutCutoffOrBoundItIsTheBackwardDifference) {
  RateEstimator r;  // f_c = +inf, no bound
  EXPECT_EQ(r.update(0.25, 0), 0.0);
  EXPECT_FALSE(r.has_rate());
  EXPECT_EQ(r.update(0.75, 2 * kMs), (0.75 - 0.25) / 2e-3);
  EXPECT_TRUE(r.has_rate());
  EXPECT_EQ(r.update(0.5, 3 * kMs), (0.5 - 0.75) / 1e-3);
}

// α = 1 − exp(−Δt/τ) is exact: on a constant slope the estimate is s (1 − exp(−(t − t₀)/τ))
// whatever the intervals (1 ms, 0.1 ms, 3 ms, a lost frame...).
TEST(RateEstimator, OnARampItIsTheExactFirstOrderResponseForAnyIntervals) {
  const double fc = 20.0, tau = 1.0 / (2.0 * kPi * fc), slope = 0.4;
  RateEstimator r(fc, kInf, false);
  const std::int64_t steps_ns[] = {kMs, kMs / 10, 3 * kMs, kMs, 7 * kMs, kMs / 2, 2 * kMs, 11 * kMs};
  std::int64_t t = 0;
  r.update(0.0, t);
  for (const std::int64_t d : steps_ns) {
    t += d;
    const double v = r.update(slope * static_cast<double>(t) * 1e-9, t);
    const double expected = slope * -std::expm1(-static_cast<double>(t) * 1e-9 / tau);
    EXPECT_NEAR(v, expected, 1e-12) << "t = " << t;
  }
}

TEST(RateEstimator, SmoothingAndDelayFormulas) {
  EXPECT_DOUBLE_EQ(RateEstimator::smoothing(50.0, 1e-3), 1.0 - std::exp(-2.0 * kPi * 50.0 * 1e-3));
  EXPECT_EQ(RateEstimator::smoothing(kInf, 1e-3), 1.0);
  EXPECT_EQ(RateEstimator::smoothing(50.0, 0.0), 0.0);
  const double tau = 1.0 / (2.0 * kPi * 50.0);
  // Δt ≪ τ: the delay tends to τ (within Δt²/(12 τ)).
  EXPECT_NEAR(RateEstimator::group_delay_s(50.0, 1e-4), tau, 1e-4 * 1e-4 / (12.0 * tau) * 1.01);
  EXPECT_NEAR(RateEstimator::group_delay_s(50.0, 1e-3), tau, 1e-3 * 1e-3 / (12.0 * tau) * 1.01);
  EXPECT_EQ(RateEstimator::group_delay_s(kInf, 1e-3), 0.5e-3);
  EXPECT_DOUBLE_EQ(RateEstimator::quantisation_bound(50.0, 1e-4, 2.0),
                   RateEstimator::smoothing(50.0, 1e-4) * 2.0 / 1e-4);
}

// A jump that passed the sample checks feeds the filter at most v_max: the estimate never
// exceeds it and its integral — what the damper pushes the tool by — is v_max Δt, not the jump.
TEST(RateEstimator, AJumpFeedsTheFilterAtMostTheBound) {
  const double vmax = 5.0, dt = 1e-3;
  RateEstimator r(kDefaultVelocityCutoffHz, vmax, false);
  r.update(0.0, 0);
  double integral = 0.0, peak = 0.0;
  for (int k = 1; k <= 2000; ++k) {
    const double x = 1.0;  // the whole 1 m jump in the first period, then still
    const double v = r.update(x, k * kMs);
    peak = std::max(peak, std::abs(v));
    integral += v * dt;
  }
  EXPECT_LE(peak, vmax);
  EXPECT_DOUBLE_EQ(peak, RateEstimator::smoothing(kDefaultVelocityCutoffHz, dt) * vmax);
  EXPECT_NEAR(integral, vmax * dt, 1e-12);
  // The bare difference integrates to the whole jump.
  RateEstimator bare;
  bare.update(0.0, 0);
  EXPECT_DOUBLE_EQ(bare.update(1.0, kMs) * dt, 1.0);
}

TEST(RateEstimator, TheBoundHoldsForBothSignsAndEveryCutoff) {
  for (const double fc : {1.0, 50.0, 1e3, kInf}) {
    RateEstimator r(fc, 2.0, false);
    r.update(0.0, 0);
    double x = 0.0;
    for (int k = 1; k <= 200; ++k) {
      x += (k % 7 < 3 ? 0.5 : -0.8) * (k % 5 == 0 ? 10.0 : 1e-3);
      const double v = r.update(x, k * kMs);
      ASSERT_LE(std::abs(v), 2.0) << "fc " << fc << " k " << k;
    }
  }
}

TEST(RateEstimator, AWrappingAxisUsesTheWrappedDifference) {
  RateEstimator r(kInf, kInf, true);
  r.update(kPi - 0.01, 0);
  EXPECT_NEAR(r.update(-kPi + 0.01, kMs), 0.02 / 1e-3, 1e-9);  // +0.02 rad across ±π
  RateEstimator plain(kInf, kInf, false);
  plain.update(kPi - 0.01, 0);
  EXPECT_NEAR(plain.update(-kPi + 0.01, kMs), -(2.0 * kPi - 0.02) / 1e-3, 1e-6);
}

TEST(RateEstimator, ATimestampNotAfterTheBaseChangesNothing) {
  RateEstimator r(kInf, kInf, false);
  r.update(0.0, 0);
  const double v = r.update(1e-3, kMs);
  EXPECT_EQ(r.update(5.0, kMs), v);      // same time: ignored
  EXPECT_EQ(r.update(5.0, kMs / 2), v);  // earlier: ignored
  EXPECT_DOUBLE_EQ(r.update(3e-3, 2 * kMs), 2e-3 / 1e-3);  // the base is still 1e-3 at 1 ms
}

TEST(RateEstimator, ResetForgetsTheBaseAndTheEstimate) {
  RateEstimator r(10.0, kInf, false);
  r.update(0.0, 0);
  r.update(1e-3, kMs);
  ASSERT_NE(r.rate(), 0.0);
  r.reset();
  EXPECT_EQ(r.rate(), 0.0);
  EXPECT_FALSE(r.has_rate());
  EXPECT_EQ(r.update(7.0, 100 * kMs), 0.0);  // a new base, no difference across the reset
  EXPECT_GT(r.update(7.001, 101 * kMs), 0.0);
}

TEST(RateEstimator, UpdateDoesNotAllocate) {
  RateEstimator r(kDefaultVelocityCutoffHz, 10.0, true);
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    for (int k = 0; k < 10000; ++k) r.update(std::sin(1e-3 * k), k * kMs / 10);
    r.reset();
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
}

// ---- A 2 Hz sine on the default trocar's pivot encoder (2^14 counts per turn) ----

using numen::test::encoder_sine::SineRun;

SineRun run_sine(double cutoff_hz, double dt) {
  return numen::test::encoder_sine::run_sine([&] { return RateEstimator(cutoff_hz, 10.0, false); },
                                             dt);
}

TEST(RateEstimatorSine, QuantisationNoiseStaysBelowAlphaQOverDtAtOneAndTenKilohertz) {
  const double q = numen::test::encoder_sine::kCount;  // rad
  for (const double dt : {1e-3, 1e-4}) {
    const SineRun f = run_sine(kDefaultVelocityCutoffHz, dt);
    const SineRun bare = run_sine(kInf, dt);
    const double bound = RateEstimator::quantisation_bound(kDefaultVelocityCutoffHz, dt, q);
    std::printf("[   info   ] %g kHz: noise max %.4f rad/s (bound %.4f), rms %.4f, error rms %.4f; "
                "bare difference max %.4f rms %.4f (q/dt %.4f), error rms %.4f\n",
                1e-3 / dt, f.noise_max, bound, f.noise_rms, f.error_rms, bare.noise_max,
                bare.noise_rms, q / dt, bare.error_rms);
    EXPECT_LE(f.noise_max, bound * (1.0 + 1e-9)) << dt;
    // The bare difference reaches most of its own bound q/Δt; the filtered peak is below 2α
    // times the bare one (α = 0.27 at 1 kHz, 0.031 at 10 kHz).
    EXPECT_GT(bare.noise_max, 0.5 * q / dt) << dt;
    EXPECT_LT(f.noise_max, 2.0 * RateEstimator::smoothing(kDefaultVelocityCutoffHz, dt) *
                               bare.noise_max) << dt;
  }
}

TEST(RateEstimatorSine, LagOnA2HzSineIsTheDocumentedDelay) {
  for (const double dt : {1e-3, 1e-4}) {
    const SineRun f = run_sine(kDefaultVelocityCutoffHz, dt);
    const SineRun bare = run_sine(kInf, dt);
    const double doc = RateEstimator::group_delay_s(kDefaultVelocityCutoffHz, dt);
    std::printf("[   info   ] %g kHz: lag %.4f ms (documented %.4f ms), gain %.5f; bare "
                "difference lag %.4f ms, gain %.5f\n",
                1e-3 / dt, f.lag_s * 1e3, doc * 1e3, f.gain, bare.lag_s * 1e3, bare.gain);
    // At 2 Hz ≪ f_c the phase delay is the group delay to (2π f τ)²/3 = 5e-4.
    EXPECT_LE(f.lag_s, doc * 1.002) << dt;
    EXPECT_GE(f.lag_s, doc * 0.99) << dt;
    EXPECT_NEAR(f.gain, 1.0 / std::hypot(1.0, 2.0 / kDefaultVelocityCutoffHz), 2e-3) << dt;
    EXPECT_NEAR(bare.lag_s, 0.5 * dt, 0.01 * dt) << dt;
  }
}

}  // namespace
