/// @file axis_plant_test.cpp
/// One axis of an emulated device (sim/device/axis_plant.hpp) against closed-form answers:
/// a free and a damped mass under a held torque, Karnopp stiction and the stop of a sliding
/// axis, the transport delay, the current loop and its saturation, the energy balance, the
/// refused settings, and no allocation.

#include "numen/sim/device/axis_plant.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <stdexcept>
#include <string>

#include "alloc_counter.hpp"

namespace numen::sim {
namespace {

AxisPlantSettings mass(double m, double b = 0.0, double fc = 0.0) {
  AxisPlantSettings s;
  s.inertia = m;
  s.damping = b;
  s.coulomb = fc;
  return s;
}

/// Runs `periods` control periods of `period` s in `substeps` steps each, commanding `torque`.
void run(AxisPlant& p, double torque, int periods, double period, int substeps,
         double external = 0.0) {
  for (int k = 0; k < periods; ++k) {
    p.command(torque);
    for (int i = 0; i < substeps; ++i) p.step(period / substeps, external);
  }
}

// A free mass under a held torque: q = ½ (τ/m) t², q̇ = (τ/m) t, whatever the sub-steps.
TEST(AxisPlant, FreeMassFollowsTheParabola) {
  for (const int substeps : {1, 7, 50}) {
    AxisPlant p(mass(0.2));
    run(p, 0.3, 1000, 1e-3, substeps);
    const double t = 1.0, a = 0.3 / 0.2;
    EXPECT_NEAR(p.q(), 0.5 * a * t * t, 1e-11) << substeps;  // rounding over 5e4 steps
    EXPECT_NEAR(p.qdot(), a * t, 1e-11) << substeps;
  }
}

// A damped mass: q̇ = (τ/b)(1 − e^{−t/τ_m}), q = (τ/b)(t − τ_m (1 − e^{−t/τ_m})), τ_m = m/b.
TEST(AxisPlant, DampedMassFollowsTheExponential) {
  const double m = 0.05, b = 2.0, tau = 0.4;
  AxisPlant p(mass(m, b));
  run(p, tau, 100, 1e-3, 3);
  const double t = 0.1, tm = m / b;
  EXPECT_NEAR(p.qdot(), tau / b * (1.0 - std::exp(-t / tm)), 1e-13);
  EXPECT_NEAR(p.q(), tau / b * (t - tm * (1.0 - std::exp(-t / tm))), 1e-13);
  // Very light damping: the closed form stays accurate (no cancellation in G/b).
  AxisPlant light(mass(1.0, 1e-12));
  run(light, 1.0, 1000, 1e-3, 1);
  EXPECT_NEAR(light.q(), 0.5, 1e-10);
}

// Karnopp: at rest, a torque at or below f_c does not move the axis; above, it accelerates
// at (τ − f_c)/m.
TEST(AxisPlant, StictionHoldsBelowTheCoulombForce) {
  AxisPlant p(mass(0.1, 0.5, 0.2));
  run(p, 0.2, 500, 1e-3, 4);
  EXPECT_EQ(p.q(), 0.0);
  EXPECT_EQ(p.qdot(), 0.0);
  EXPECT_TRUE(p.stuck());
  run(p, -0.19, 500, 1e-3, 4, -0.01);  // the hand's force counts too: |−0.2| <= f_c
  EXPECT_EQ(p.q(), 0.0);
  AxisPlant slides(mass(0.1, 0.0, 0.2));
  run(slides, 0.3, 100, 1e-3, 1);
  EXPECT_FALSE(slides.stuck());
  EXPECT_NEAR(slides.qdot(), (0.3 - 0.2) / 0.1 * 0.1, 1e-12);
}

// A sliding axis with no torque stops where friction has taken its kinetic energy
// (d = m v0² / (2 f_c), at t = m v0 / f_c), mid-step, and stays there.
TEST(AxisPlant, SlidingAxisStopsExactlyAndStays) {
  AxisPlant p(mass(0.1, 0.0, 0.2));
  p.reset(0.01, 0.3);
  run(p, 0.0, 1000, 1e-3, 1);  // stops at t = 0.15 s, inside a step
  EXPECT_NEAR(p.q(), 0.01 + 0.1 * 0.09 / 0.4, 1e-14);
  EXPECT_EQ(p.qdot(), 0.0);
  EXPECT_TRUE(p.stuck());
  EXPECT_NEAR(p.energy().friction, 0.5 * 0.1 * 0.09, 1e-15);
  // With damping too, the stop instant solves v(t*) = 0 of the closed form.
  AxisPlant d(mass(0.1, 0.5, 0.2));
  d.reset(0.0, 0.3);
  run(d, 0.0, 1000, 1e-3, 1);
  const double tm = 0.1 / 0.5, v_inf = -0.2 / 0.5;
  const double t_stop = tm * std::log(1.0 - 0.3 / v_inf);
  EXPECT_NEAR(d.q(), v_inf * t_stop + (0.3 - v_inf) * tm * (1.0 - std::exp(-t_stop / tm)), 1e-14);
  EXPECT_EQ(d.qdot(), 0.0);
}

// A command reaches the drive `delay_periods` commands later; before, the drive applies 0.
TEST(AxisPlant, TransportDelayHoldsTheCommandBackWholePeriods) {
  AxisPlantSettings s = mass(1.0);
  s.delay_periods = 3;
  AxisPlant p(s);
  for (int k = 0; k < 6; ++k) {
    p.command(k + 1.0);
    p.step(1e-3);
    EXPECT_EQ(p.applied_torque(), k < 3 ? 0.0 : k - 2.0) << k;
  }
  s.delay_periods = kMaxPlantDelayPeriods + 1;
  EXPECT_THROW(AxisPlant{s}, std::invalid_argument);
}

// The current loop: the applied torque over a step is the exact mean of the first-order
// response; it settles on the command and saturates at max_torque.
TEST(AxisPlant, CurrentLoopLagsAndSaturates) {
  AxisPlantSettings s = mass(1.0);
  s.current_lag_s = 1e-3;
  AxisPlant p(s);
  p.command(2.0);
  p.step(1e-3);
  EXPECT_NEAR(p.applied_torque(), 2.0 * (1.0 - (1.0 - std::exp(-1.0))), 1e-14);
  for (int k = 0; k < 40; ++k) p.step(1e-3);
  EXPECT_NEAR(p.applied_torque(), 2.0, 1e-12);
  s.current_lag_s = 0.0;
  s.max_torque = 0.5;
  AxisPlant sat(s);
  sat.command(-2.0);
  sat.step(1e-3);
  EXPECT_EQ(sat.applied_torque(), -0.5);
  sat.command(std::nan(""));
  sat.step(1e-3);
  EXPECT_EQ(sat.applied_torque(), 0.0) << "a non-finite command is applied as 0";
}

// Whatever goes in (drive, hand) is the kinetic energy gained plus what friction and the
// damper took.
TEST(AxisPlant, EnergyBalances) {
  AxisPlant p(mass(0.05, 0.8, 0.05));
  double external = 0.0;
  for (int k = 0; k < 3000; ++k) {
    p.command(0.3 * std::sin(k * 0.01));
    external = -5.0 * p.q();  // a spring, held over each sub-step
    for (int i = 0; i < 5; ++i) p.step(2e-4, external, 0.01, 0.1);
  }
  const AxisPlantEnergy& e = p.energy();
  const double kinetic = 0.5 * (0.05 + 0.01) * p.qdot() * p.qdot();
  EXPECT_NEAR(e.drive + e.external, kinetic + e.friction + e.damping, 1e-12);
  EXPECT_GT(e.friction, 0.0);
  EXPECT_GT(e.damping, 0.0);
}

TEST(AxisPlant, RefusesSettingsOutOfRangeNamingThem) {
  const auto message = [](const AxisPlantSettings& s) {
    try {
      AxisPlant p(s);
    } catch (const std::invalid_argument& e) {
      return std::string(e.what());
    }
    return std::string("accepted");
  };
  AxisPlantSettings s = mass(0.0);
  EXPECT_NE(message(s).find("inertia"), std::string::npos);
  s = mass(std::nan(""));
  EXPECT_NE(message(s).find("inertia"), std::string::npos);
  s = mass(1.0, -1.0);
  EXPECT_NE(message(s).find("damping"), std::string::npos);
  s = mass(1.0, 0.0, std::nan(""));
  EXPECT_NE(message(s).find("coulomb"), std::string::npos);
  s = mass(1.0);
  s.current_lag_s = -1e-3;
  EXPECT_NE(message(s).find("current_lag"), std::string::npos);
  s = mass(1.0);
  s.max_torque = 0.0;
  EXPECT_NE(message(s).find("max_torque"), std::string::npos);
  s.max_torque = 1.0;
  s.delay_periods = -1;
  EXPECT_NE(message(s).find("delay_periods"), std::string::npos);
}

TEST(AxisPlant, CommandAndStepNeverAllocate) {
  AxisPlantSettings s = mass(0.1, 0.2, 0.05);
  s.delay_periods = 5;
  s.current_lag_s = 2e-4;
  AxisPlant p(s);
  numen::test::AllocationGuard guard;
  run(p, 0.4, 200, 1e-3, 10, -0.1);
  EXPECT_EQ(guard.count(), 0);
}

}  // namespace
}  // namespace numen::sim
