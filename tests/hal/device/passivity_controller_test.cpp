// Tests of numen/hal/device/passivity_controller.hpp: the observer's arithmetic
// E(n) = E(n−1) − T τ v, no action while the port is passive, the damper α = −E / (T v²) that
// brings E back to 0 on an active sequence, the velocity threshold, the energy limit, the axis
// mask and the caller's gate, sent()'s booking of what the clamp took away, the settings' checks, and no
// allocation in a period.
#include "numen/hal/device/passivity_controller.hpp"

#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <span>
#include <stdexcept>

#include "alloc_counter.hpp"

namespace {

using numen::hal::PassivityController;

constexpr double kT = 1e-3;

TEST(PassivityController, ObserverAddsTheEnergyIntoTheEnvironmentAndLeavesAPassivePortAlone) {
  PassivityController pc(2, kT, 0b11, 0.0);
  // A spring being compressed then released: τ = −k x with x = 0.5, 0.75 (k = 4).
  std::array<double, 2> tau = {-2.0, 0.5};
  std::array<double, 2> v = {0.5, -0.25};
  EXPECT_EQ(pc.apply(tau, v), 0);
  EXPECT_EQ(pc.energy(0), 0.0 - kT * -2.0 * 0.5);
  EXPECT_EQ(pc.energy(1), 0.0 - kT * 0.5 * -0.25);
  EXPECT_EQ(tau[0], -2.0);  // passive: the torques pass untouched
  EXPECT_EQ(tau[1], 0.5);
  const double e0 = pc.energy(0);
  tau = {-3.0, 0.0};
  v = {-0.25, 0.0};
  EXPECT_EQ(pc.apply(tau, v), 0);
  EXPECT_EQ(pc.energy(0), e0 - kT * -3.0 * -0.25);  // 1e-3 − 0.75e-3: still >= 0
  EXPECT_GT(pc.energy(0), 0.0);
  EXPECT_EQ(tau[0], -3.0);
  EXPECT_EQ(pc.damping(0), 0.0);
  EXPECT_EQ(pc.counters().acting_periods, 0u);
  EXPECT_EQ(pc.counters().dissipated_j, 0.0);
}

TEST(PassivityController, DamperBringsTheEnergyBackToZeroOnAnActiveSequence) {
  // A "negative spring" τ = +k x driven along x: it produces energy every period.
  PassivityController pc(1, kT, 0b1, 1e-3);
  const double k = 500.0, v = 0.05;
  double x = 0.0, dissipated = 0.0;
  for (int n = 1; n <= 200; ++n) {
    x += v * kT;
    const double env = k * x;
    std::array<double, 1> tau = {env};
    const std::array<double, 1> rate = {v};
    const double before = pc.energy(0);
    ASSERT_EQ(pc.apply(tau, rate), 1) << n;  // active at every period
    const double observed = before - kT * env * v;
    ASSERT_LT(observed, 0.0) << n;
    const double alpha = -observed / (kT * v * v);
    EXPECT_DOUBLE_EQ(pc.damping(0), alpha) << n;
    EXPECT_DOUBLE_EQ(tau[0], env - alpha * v) << n;
    EXPECT_NEAR(pc.energy(0), 0.0, 1e-15) << n;  // E >= 0 up to rounding
    dissipated += kT * alpha * v * v;
    // Power into the controlled port this period: −τ v T >= 0 once E is 0.
    EXPECT_NEAR(before - kT * tau[0] * v, 0.0, 1e-15) << n;
  }
  EXPECT_EQ(pc.counters().acting_periods, 200u);
  EXPECT_EQ(pc.counters().axis_acting_periods[0], 200u);
  EXPECT_NEAR(pc.counters().dissipated_j, dissipated, 1e-15);
  // Energy the environment produced = energy the damper took: Σ T k x v.
  double produced = 0.0;
  for (int n = 1; n <= 200; ++n) produced += kT * k * (n * v * kT) * v;
  EXPECT_NEAR(pc.counters().dissipated_j, produced, 1e-12);
}

TEST(PassivityController, DoesNotActBelowTheVelocityThreshold) {
  PassivityController pc(1, kT, 0b1, 0.01);
  std::array<double, 1> tau = {5.0};
  std::array<double, 1> rate = {0.2};
  EXPECT_EQ(pc.apply(tau, rate), 1);  // E = −1e-3 → damped to 0
  EXPECT_NEAR(pc.energy(0), 0.0, 1e-18);
  tau = {5.0};
  rate = {0.01};  // |v| = v_min: observed, not controlled
  EXPECT_EQ(pc.apply(tau, rate), 0);
  EXPECT_EQ(tau[0], 5.0);
  EXPECT_NEAR(pc.energy(0), -kT * 5.0 * 0.01, 1e-18);  // the deficit is kept
  EXPECT_EQ(pc.damping(0), 0.0);
  tau = {0.0};
  rate = {-0.1};  // moving again: the deficit is dissipated
  EXPECT_EQ(pc.apply(tau, rate), 1);
  EXPECT_NEAR(tau[0], -(5e-5 / (kT * 0.01)) * -0.1, 1e-12);
  EXPECT_NEAR(pc.energy(0), 0.0, 1e-18);
}

TEST(PassivityController, OnlyTheMaskedAndAllowedAxesAreObservedAndControlled) {
  PassivityController pc(3, kT, 0b101, 0.0);
  std::array<double, 3> tau = {1.0, 1.0, 1.0};
  std::array<double, 3> rate = {1.0, 1.0, 1.0};
  EXPECT_EQ(pc.apply(tau, rate, /*allowed=*/0b011), 1);  // axis 2 gated, axis 1 not in the mask
  EXPECT_NE(tau[0], 1.0);
  EXPECT_EQ(tau[1], 1.0);
  EXPECT_EQ(tau[2], 1.0);
  EXPECT_EQ(pc.energy(1), 0.0);
  EXPECT_EQ(pc.energy(2), 0.0);
  EXPECT_EQ(pc.energy(7), 0.0);   // beyond num_axes
  EXPECT_EQ(pc.energy(-1), 0.0);
  // Missing entries count as 0; non-finite ones skip the axis.
  std::array<double, 1> short_tau = {std::nan("")};
  EXPECT_EQ(pc.apply(short_tau, std::span<const double>{}), 0);
  EXPECT_NEAR(pc.energy(0), 0.0, 1e-18);
}

TEST(PassivityController, SentBooksWhatTheClampTookAway) {
  PassivityController pc(1, kT, 0b1, 0.0);
  std::array<double, 1> tau = {-4.0};  // passive: E = 4e-3 · v
  const std::array<double, 1> rate = {0.5};
  pc.apply(tau, rate);
  EXPECT_DOUBLE_EQ(pc.energy(0), 2e-3);
  const std::array<double, 1> clamped = {-1.0};  // the clamp sent −1
  pc.sent(clamped);
  EXPECT_DOUBLE_EQ(pc.energy(0), kT * 1.0 * 0.5);  // E of what was sent
  pc.sent(clamped);  // nothing observed since: no effect
  EXPECT_DOUBLE_EQ(pc.energy(0), 5e-4);
  pc.reset();
  EXPECT_EQ(pc.energy(0), 0.0);
  EXPECT_EQ(pc.counters().acting_periods, 0u);
}

TEST(PassivityController, EnergyLimitCapsTheMarginADissipativeRenderBuildsUp) {
  PassivityController paper(1, kT, 0b1, 0.0);
  PassivityController tank(1, kT, 0b1, 0.0, 1e-4);
  const std::array<double, 1> rate = {0.5};
  for (int n = 0; n < 100; ++n) {  // a damper: 1 mJ per period into the environment
    std::array<double, 1> a = {-2.0}, b = {-2.0};
    paper.apply(a, rate);
    tank.apply(b, rate);
  }
  EXPECT_NEAR(paper.energy(0), 0.1, 1e-12);
  EXPECT_EQ(tank.energy(0), 1e-4);
  // Then a render that produces 1 mJ per period: the paper's observer waits 100 periods, the
  // capped one damps from the first.
  std::array<double, 1> a = {2.0}, b = {2.0};
  EXPECT_EQ(paper.apply(a, rate), 0);
  EXPECT_EQ(tank.apply(b, rate), 1);
  EXPECT_NEAR(tank.energy(0), 0.0, 1e-18);
  EXPECT_NEAR(b[0], 2.0 - (0.9e-3 / (kT * 0.25)) * 0.5, 1e-12);
  const std::array<double, 1> sent = {-5.0};  // sent() is capped too
  tank.sent(sent);
  EXPECT_EQ(tank.energy(0), 1e-4);
}

TEST(PassivityController, ConstructorRejectsBadSettings) {
  EXPECT_THROW(PassivityController(-1, kT, 1), std::invalid_argument);
  EXPECT_THROW(PassivityController(numen::hal::kMaxAxes + 1, kT, 1), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, 0.0, 1), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, std::nan(""), 1), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, kT, 1, -1e-3), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, kT, 1, INFINITY), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, kT, 1, 0.0, 0.0), std::invalid_argument);
  EXPECT_THROW(PassivityController(1, kT, 1, 0.0, std::nan("")), std::invalid_argument);
  EXPECT_NO_THROW(PassivityController(0, kT, 0));
}

TEST(PassivityController, APeriodDoesNotAllocate) {
  PassivityController pc(numen::hal::kMaxAxes, kT, 0xFF, 1e-3);
  std::array<double, numen::hal::kMaxAxes> tau{};
  std::array<double, numen::hal::kMaxAxes> rate{};
  std::int64_t allocations = 0;
  {
    numen::test::AllocationGuard guard;
    for (int n = 0; n < 100; ++n) {
      tau.fill(1.0 + n);
      rate.fill(0.1);
      pc.apply(tau, rate);
      pc.sent(tau);
    }
    allocations = guard.count();
  }
  EXPECT_EQ(allocations, 0);
  EXPECT_EQ(pc.counters().acting_periods, 100u);
}

}  // namespace
